"""Do the HAL's arm joints match the kinematic model's?

The KCL computes one velocity per joint of the URDF model, in the model's
order; the HAL sends them to its joints in the HAL's order. They must be the
same joints, in the same order, with the same names (a name mismatch is how a
swapped cable or a config written for another arm shows before anything
moves). Used by ``maris hal check``, ``maris validate --hal`` and the run's
preflight.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any


def joint_mismatch(
    hal_names: Sequence[str], model_names: Sequence[str], *, model: str = "the model (URDF)"
) -> str | None:
    """Why the HAL's joints (``hal_names``, in order) do not match the model's, or None."""
    hal_names, model_names = list(hal_names), list(model_names)
    if len(hal_names) != len(model_names):
        return (
            f"the HAL arm has {len(hal_names)} joint(s) ({', '.join(hal_names) or 'none'}), "
            f"{model} has {len(model_names)} ({', '.join(model_names)})"
        )
    wrong = [
        f"#{i + 1} is `{h}` in the HAL, `{m}` in {model}"
        for i, (h, m) in enumerate(zip(hal_names, model_names))
        if h != m
    ]
    if wrong:
        return "joint names differ (they must match in order): " + "; ".join(wrong)
    return None


def hal_joint_names(config: Any) -> list[str] | None:
    """Arm joint names a HAL config declares (None: they come from the model, e.g. the simulator)."""
    arm = config.devices.get("arm") if hasattr(config, "devices") else None
    if arm is None or arm.driver == "sim":
        return None
    return [j.get("name") for j in arm.params.get("joints") or []]
