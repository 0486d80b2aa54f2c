"""Keep Numba's on-disk caches honest across files.

Numba (``cache=True``) stores a compiled function, together with every
compiled function it calls, under ``__pycache__``, and reuses it as long as
the function's OWN source file is unchanged: it does not notice that a callee
in another file was edited, and keeps running the old callee. The KCL has such
calls (the TPIK kernel calls :mod:`kcl.small_linalg`, the task batch calls every
task's row kernel, the manipulability kernel calls :mod:`kcl.small_linalg`).

:func:`drop_stale` is called by those modules at import, before any of their
functions runs: it deletes their cache files that are older than one of the
files they depend on, so Numba recompiles them (seconds, once). Caches kept
elsewhere (``NUMBA_CACHE_DIR``, read-only installs) are left alone.
"""

from __future__ import annotations

import os
from pathlib import Path

#: Options of every KCL kernel: cached on disk, and holding the interpreter lock
#: while it runs. A kernel that released it (``nogil=True``) let the drivers'
#: reader threads in during the control step and then waited for them to hand it
#: back at its return: in a field run (10 CANopen drives, MAVLink, DVL, AHRS) the
#: arm step's one compiled call took ~80 us instead of ~20, and up to 10 ms when a
#: thread kept the lock for its switch interval. The control step is the only
#: caller; nothing runs KCL kernels in parallel.
KERNEL_OPTIONS = {"cache": True, "nogil": False}


def drop_stale(module_file: str, dependencies: list[str]) -> int:
    """Delete ``module_file``'s Numba cache files older than any of
    ``dependencies`` (source files). Returns how many were deleted."""
    src = Path(module_file)
    cache_dir = src.parent / "__pycache__"
    try:
        newest = max(os.stat(d).st_mtime for d in dependencies)
        entries = list(cache_dir.glob(f"{src.stem}.*.nb[ic]"))
    except OSError:
        return 0
    dropped = 0
    for entry in entries:
        try:
            if entry.stat().st_mtime < newest:
                entry.unlink()
                dropped += 1
        except OSError:  # another process got there first, or no permission
            continue
    return dropped
