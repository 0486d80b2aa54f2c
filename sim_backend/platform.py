"""Which rig a scenario simulates: its URDF and actions file (``platform.model``,
``platform.actions``).

A value is a file name in ``kcl/data/`` (``bluerov2_heavy_alpha5.urdf``) or a path,
absolute or relative to the scenario file that sets it (a scenario that
``extends:`` another inherits its values, still relative to the one that set
them). Empty: the scenario does not say (the run's default rig).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from maris_common.yamlsrc import ConfigError, ConfigIssue, Mark

from .scenario import Scenario, _read_layers

KCL_DATA = Path(__file__).resolve().parent.parent / "kcl" / "data"


@dataclass(frozen=True)
class PlatformRef:
    """A file a scenario names for its rig, and where (``file:line:column``) it names it."""

    path: Path
    mark: Mark


def _locate(scenario: Scenario, key: str) -> tuple[str, Mark] | None:
    """The raw value of ``platform.<key>`` and where the last layer setting it wrote it."""
    found = None
    for src, data in _read_layers(Path(scenario.source), (Path(scenario.source).stem,)):
        section = data.get("platform")
        if isinstance(section, dict) and isinstance(section.get(key), str):
            found = (section[key], src.mark(("platform", key)))
    return found


def scenario_file(scenario: Scenario, key: str) -> PlatformRef | None:
    """The file ``platform.<key>`` (``model`` or ``actions``) names, or None when the
    scenario names none. ConfigError (at the scenario's line) for a file that does not exist."""
    value = str(scenario.values.get(f"platform.{key}") or "")
    if not value:
        return None
    located = _locate(scenario, key)
    mark = located[1] if located is not None and located[0] == value else Mark(scenario.source, 1, 1)
    raw = Path(value)
    candidates = [raw] if raw.is_absolute() else [Path(mark.file).resolve().parent / raw, KCL_DATA / raw]
    for c in candidates:
        if c.is_file():
            return PlatformRef(c.resolve(), mark)
    raise ConfigError(
        [
            ConfigIssue(
                mark,
                ("platform", key),
                f"file not found: {value} (looked in {', '.join(str(c.parent) for c in candidates)})",
            )
        ]
    )
