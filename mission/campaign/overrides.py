"""``--set key=value`` options of ``maris campaign``.

Values are parsed as YAML with the safe loader (``true``, ``3.5``, ``.inf``,
``[1, 2]``, ``null``), never evaluated. Keys under ``controller.`` are controller
options of the run; every other key is a dotted scenario override passed to
``sim_backend.load_scenario`` (which checks that the key exists).

Errors are :class:`maris_common.yamlsrc.ConfigError` naming the option as
``--set:N:COL`` (N = the option's position among the ``--set`` options).
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import yaml

from maris_common.yamlsrc import ConfigError, ConfigIssue, Mark

#: Controller options a campaign may set, with the check each value must pass.
CONTROLLER_OPTIONS: dict[str, str] = {
    "compensation": "true or false: optimize the arm against the measured vehicle velocity",
    "filter_cutoff_rad_s": "cutoff of the first-order feedback filter in rad/s; .inf or null disables it",
}

SOURCE = "--set"


@dataclass
class Settings:
    """Parsed ``--set`` options: scenario overrides and controller options."""

    scenario: dict[str, Any] = field(default_factory=dict)
    controller: dict[str, Any] = field(default_factory=dict)
    #: key -> 1-based position of its ``--set`` option (for error marks)
    positions: dict[str, int] = field(default_factory=dict)


def _check_controller(name: str, value: Any) -> str | None:
    if name == "compensation":
        return None if isinstance(value, bool) else f"expected true or false, got {value!r}"
    if name == "filter_cutoff_rad_s":
        if value is None:
            return None
        if isinstance(value, bool) or not isinstance(value, (int, float)) or math.isnan(value) or value <= 0:
            return f"expected a positive number of rad/s (or .inf / null to disable), got {value!r}"
        return None
    return None


def parse_settings(items: Sequence[str]) -> Settings:
    """Parse ``key=value`` strings; all problems are reported at once (ConfigError)."""
    out, issues = collect_settings(items)
    if issues:
        raise ConfigError(issues)
    return out


def collect_settings(items: Sequence[str]) -> tuple[Settings, list[ConfigIssue]]:
    """Like :func:`parse_settings` but returns the valid settings and the problems."""
    out = Settings()
    issues: list[ConfigIssue] = []
    for n, item in enumerate(items, start=1):
        key, sep, text = item.partition("=")
        key = key.strip()
        if not sep or not key:
            issues.append(ConfigIssue(Mark(SOURCE, n, 1), (), f"{item!r}: expected key=value"))
            continue
        if any(not part for part in key.split(".")):
            issues.append(ConfigIssue(Mark(SOURCE, n, 1), (key,), "empty component in dotted key"))
            continue
        col = len(item) - len(item.partition("=")[2]) + 1
        try:
            value = yaml.safe_load(text) if text.strip() else None
        except yaml.YAMLError as exc:
            issues.append(ConfigIssue(Mark(SOURCE, n, col), (key,), f"value is not valid YAML: {exc}".splitlines()[0]))
            continue
        if key.startswith("controller."):
            name = key[len("controller.") :]
            if name not in CONTROLLER_OPTIONS:
                near = difflib.get_close_matches(name, CONTROLLER_OPTIONS, n=1)
                hint = f" (did you mean controller.{near[0]}?)" if near else ""
                known = ", ".join(f"controller.{k}" for k in CONTROLLER_OPTIONS)
                issues.append(
                    ConfigIssue(Mark(SOURCE, n, 1), (key,), f"unknown controller option{hint}; known: {known}")
                )
                continue
            problem = _check_controller(name, value)
            if problem:
                issues.append(ConfigIssue(Mark(SOURCE, n, col), (key,), problem))
                continue
            out.controller[name] = value
        else:
            out.scenario[key] = value
        out.positions[key] = n
    return out, issues
