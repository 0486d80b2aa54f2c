"""MeasuredState.of (the runtime's per-step constructor) builds the same frozen object as the dataclass's __init__."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from kcl.controller_types import MeasuredState, kernel_ready


def test_of_equals_the_constructed_one() -> None:
    q, eta, v = np.arange(7.0), np.arange(6.0), np.ones(6)
    for args in ((q, eta, v, 1.25, 0.8), (q, eta, None, 2.0, None)):
        fast, slow = MeasuredState.of(*args), MeasuredState(*args)
        assert type(fast) is MeasuredState
        assert vars(fast).keys() == vars(slow).keys()
        for f in dataclasses.fields(MeasuredState):
            assert getattr(fast, f.name) is getattr(slow, f.name)
    assert MeasuredState.of(q, eta, v, 1.0).altitude is None  # the same default


def test_of_stays_frozen() -> None:
    m = MeasuredState.of(np.zeros(7), np.zeros(6), None, 0.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        m.t = 1.0  # type: ignore[misc]
    assert not hasattr(MeasuredState, "__post_init__") and not hasattr(MeasuredState, "__slots__")


def _read_only(x: np.ndarray) -> np.ndarray:
    x = np.array(x, dtype=float)
    x.setflags(write=False)
    return x


def test_kernel_ready_keeps_kernel_arrays_and_copies_the_others() -> None:
    """Writable contiguous float64 arrays pass as they are (the same object); read-only,
    strided or other-typed ones become such copies with the same values (NaN kept)."""
    q, eta, v = np.arange(7.0), np.arange(6.0), np.ones(6)
    meas = MeasuredState.of(q, eta, v, 1.0, 0.5)
    assert kernel_ready(meas) is meas
    assert kernel_ready(MeasuredState.of(q, eta, None, 1.0)).v is None
    odd = (
        (_read_only(q), eta, v),
        (q, np.arange(12.0)[::2], v),
        (q, eta, [0.0, 1.0, np.nan, 3.0, 4.0, 5.0]),
        (np.arange(7, dtype=np.float32), eta, v),
    )
    for args in odd:
        ready = kernel_ready(MeasuredState.of(*args, 2.5, 1.5))
        assert (ready.t, ready.altitude) == (2.5, 1.5)
        for got, given in zip((ready.q, ready.eta, ready.v), args):
            assert type(got) is np.ndarray and got.dtype == np.float64
            assert got.flags.writeable and got.flags.c_contiguous
            np.testing.assert_array_equal(got, np.asarray(given, dtype=float))
    read_only = odd[0][0]
    assert not read_only.flags.writeable  # the caller's read-only reading stays read-only: copied, not unlocked
