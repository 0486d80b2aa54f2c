"""Helpers of the KCL tests (imported by name: tests/kcl/conftest.py puts this folder on the path)."""

from __future__ import annotations

from typing import Any

from kcl.stacking import UNSOLVED


def count_fused(ctrl: Any, name: str, fused: bool) -> list[int]:
    """Wrap the controller's one-call path ``name`` (``_arm_fused`` or ``_vehicle_fused``):
    with ``fused`` False it always declines (the step by step path runs); returns a
    one-element list counting the steps it took."""
    hits = [0]
    inner = getattr(ctrl, name)

    def counted(meas: Any, t: float) -> Any:
        out = inner(meas, t) if fused else UNSOLVED
        hits[0] += out is not UNSOLVED
        return out

    setattr(ctrl, name, counted)
    return hits
