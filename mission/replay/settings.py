"""``--set controller.KEY=VALUE`` options of ``maris log replay`` (what-if).

Values are YAML read with the safe loader (``true``, ``25``, ``.inf``,
``[0.3, 0.3, 0.2, 0.1, 0.1, 0.2]``, ``null``), never evaluated. Problems are a
:class:`maris_common.yamlsrc.ConfigError` naming the option as ``--set:N:COL``
(N: the option's position among the ``--set`` options), all at once.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Sequence
from typing import Any

import yaml

from maris_common.yamlsrc import ConfigError, ConfigIssue, Mark
from mission.runtime.options import NO_FILTER_CUTOFF_RAD_S

__all__ = ["CONTROLLER_SETTINGS", "NO_FILTER_CUTOFF_RAD_S", "NO_FILTER_VALUES", "parse_settings"]

SOURCE = "--set"

#: Values of ``controller.filter_cutoff_rad_s`` meaning "no filter" (YAML reads ``off`` as false).
NO_FILTER_VALUES = (None, False, "off", "none", "inf")

#: Controller options a what-if may change, with what each value must be.
CONTROLLER_SETTINGS: dict[str, str] = {
    "filter_cutoff_rad_s": "a positive number of rad/s (off, .inf or null: no filter)",
    "compensation": "true or false (the arm optimizes against the measured vehicle velocity)",
    "vehicle_velocity_limit": "six positive numbers, |u v w| in m/s and |p q r| in rad/s",
    "joint_velocity_limit": "one positive number of rad/s per joint, or null for the URDF's",
    "lam": "a positive number (regularization), or null for the actions file's",
    "threshold": "a positive number (singular value threshold), or null for the actions file's",
    "eta": "a number >= 0 (weight of the (I - Q) term)",
}


def _number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and not math.isnan(v)


def check_value(name: str, value: Any) -> tuple[Any, str | None]:
    """(value to use, problem or None) for controller option ``name``."""
    if name == "compensation":
        return value, None if isinstance(value, bool) else f"expected true or false, got {value!r}"
    if name == "filter_cutoff_rad_s":
        off = value is None or value is False or (isinstance(value, str) and value.lower() in NO_FILTER_VALUES)
        if off or (_number(value) and math.isinf(value) and value > 0):
            return NO_FILTER_CUTOFF_RAD_S, None
        ok = _number(value) and value > 0
        return float(value) if ok else value, None if ok else f"expected {CONTROLLER_SETTINGS[name]}, got {value!r}"
    if name in ("lam", "threshold"):
        if value is None:
            return None, None
        ok = _number(value) and 0 < value < math.inf
        return float(value) if ok else value, None if ok else f"expected {CONTROLLER_SETTINGS[name]}, got {value!r}"
    if name == "eta":
        ok = _number(value) and 0 <= value < math.inf
        return float(value) if ok else value, None if ok else f"expected {CONTROLLER_SETTINGS[name]}, got {value!r}"
    if name == "joint_velocity_limit" and value is None:
        return None, None
    ok = isinstance(value, list) and bool(value) and all(_number(x) and x > 0 for x in value)
    if name == "vehicle_velocity_limit":
        ok = ok and len(value) == 6
    return (
        tuple(float(x) for x in value) if ok else value
    ), None if ok else f"expected {CONTROLLER_SETTINGS[name]}, got {value!r}"


def parse_settings(items: Sequence[str]) -> dict[str, Any]:
    """``["controller.lam=0.02", ...]`` -> ``{"lam": 0.02}`` (ConfigError on any problem)."""
    out: dict[str, Any] = {}
    issues: list[ConfigIssue] = []
    for n, item in enumerate(items, start=1):
        key, sep, text = item.partition("=")
        key = key.strip()
        col = len(key) + 2
        if not sep or not key:
            issues.append(ConfigIssue(Mark(SOURCE, n, 1), (), f"{item!r}: expected controller.KEY=VALUE"))
            continue
        name = key[len("controller.") :] if key.startswith("controller.") else None
        if name not in CONTROLLER_SETTINGS:
            near = difflib.get_close_matches(key.split(".")[-1], CONTROLLER_SETTINGS, n=1)
            hint = f" (did you mean controller.{near[0]}?)" if near else ""
            known = ", ".join(f"controller.{k}" for k in CONTROLLER_SETTINGS)
            issues.append(
                ConfigIssue(
                    Mark(SOURCE, n, 1),
                    (key,),
                    f"unknown setting{hint}; a replay can change: {known} (a changed mission: --mission FILE)",
                )
            )
            continue
        try:
            value = yaml.safe_load(text) if text.strip() else None
        except yaml.YAMLError as exc:
            issues.append(ConfigIssue(Mark(SOURCE, n, col), (key,), f"value is not valid YAML: {exc}".splitlines()[0]))
            continue
        value, problem = check_value(name, value)
        if problem:
            issues.append(ConfigIssue(Mark(SOURCE, n, col), (key,), problem))
            continue
        out[name] = value
    if issues:
        raise ConfigError(issues)
    return out
