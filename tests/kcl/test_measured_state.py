"""MeasuredState.of (the runtime's per-step constructor) builds the same frozen object as the dataclass's __init__."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from kcl.controller_types import MeasuredState


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
