"""Small symmetric eigendecompositions for the numpy TPIK path of :mod:`kcl.icat`.

LAPACK ``dsyev`` is called directly through SciPy's Cython LAPACK table with
preallocated per-thread buffers (~1-2 us instead of numpy.linalg.eigh's ~8 us
of Python-level checks); without SciPy's table, numpy.linalg.eigh is used.
"""

from __future__ import annotations

import threading

import numpy as np


def _load_dsyev():
    """LAPACK dsyev as a ctypes function (from SciPy's Cython LAPACK table),
    or None when unavailable; numpy.linalg.eigh is then used instead."""
    try:
        import ctypes

        from scipy.linalg import cython_lapack

        capsule = cython_lapack.__pyx_capi__["dsyev"]
        api = ctypes.pythonapi
        api.PyCapsule_GetName.restype = ctypes.c_char_p
        api.PyCapsule_GetName.argtypes = [ctypes.py_object]
        api.PyCapsule_GetPointer.restype = ctypes.c_void_p
        api.PyCapsule_GetPointer.argtypes = [ctypes.py_object, ctypes.c_char_p]
        address = api.PyCapsule_GetPointer(capsule, api.PyCapsule_GetName(capsule))
        if not address:
            return None
        return ctypes.CFUNCTYPE(None, *([ctypes.c_void_p] * 9))(address)
    except Exception:  # no SciPy, or a SciPy without the table: numpy fallback
        return None


_DSYEV_STATE: list = []  # [dsyev function or None], filled on first use (imports SciPy)


def _dsyev():
    if not _DSYEV_STATE:
        _DSYEV_STATE.append(_load_dsyev())
    return _DSYEV_STATE[0]


class _EighWorkspace:
    """Preallocated dsyev buffers for one matrix size (one per thread and slot).

    Calling LAPACK directly with cached pointers costs ~1-2 us instead of the
    ~8 us of numpy.linalg.eigh's Python-level checks. Results are views into
    the buffers: valid until the next call on the same workspace.
    """

    def __init__(self, n: int):
        import ctypes

        self.n = n
        self.a = np.zeros((n, n))
        self.w = np.zeros(n)
        lwork = max(1, 66 * n)
        self.work = np.zeros(lwork)
        ints = np.array([n, lwork, 0], dtype=np.intc)
        self.ints = ints
        self.jobz = ctypes.create_string_buffer(b"V")
        self.uplo = ctypes.create_string_buffer(b"L")
        base = ints.ctypes.data
        size = ints.itemsize
        self.args = (
            ctypes.addressof(self.jobz),
            ctypes.addressof(self.uplo),
            base,
            self.a.ctypes.data,
            base,
            self.w.ctypes.data,
            self.work.ctypes.data,
            base + size,
            base + 2 * size,
        )


_local = threading.local()


def _workspace(n: int, slot: int) -> _EighWorkspace:
    try:
        cache = _local.cache
    except AttributeError:
        cache = _local.cache = {}
    ws = cache.get((n, slot))
    if ws is None:
        ws = cache[(n, slot)] = _EighWorkspace(n)
    return ws


def _eigh_product(L: np.ndarray, R: np.ndarray, slot: int) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues (ascending) and eigenvectors (columns) of the symmetric
    product ``L @ R`` (e.g. ``Z.T @ Z``), formed straight into the LAPACK buffer.

    ``slot`` separates results that must stay alive together: the returned
    arrays are views into per-thread, per-(size, slot) buffers, valid until
    the next call with the same size and slot.
    """
    dsyev = _DSYEV_STATE[0] if _DSYEV_STATE else _dsyev()
    if dsyev is None:
        return np.linalg.eigh(np.dot(L, R))
    ws = _workspace(L.shape[0], slot)
    np.dot(L, R, out=ws.a)  # symmetric: row/column-major storage agree
    dsyev(*ws.args)
    if ws.ints[2] != 0:  # LAPACK did not converge: let numpy try (and raise)
        return np.linalg.eigh(np.dot(L, R))
    return ws.w, ws.a.T
