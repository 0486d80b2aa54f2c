"""Which rig a mission runs on: the URDF model and the KCL actions file.

One mission tree runs on several rigs (the MARIS R2 with its UMA arm, a BlueROV2
Heavy with a Reach Alpha 5); what differs is data. Three places may name the
model and the actions file, and the first that does wins:

1. the mission's own ``model`` / ``actions_file`` fields;
2. the HAL config's ``model`` / ``actions`` (the devices are that rig);
3. the simulator scenario's ``platform.model`` / ``platform.actions`` (the
   simulated world is that rig; a dry run without a HAL config of its own);

then the shipped default (``kcl/data/r2_uma.urdf``, ``kcl/data/actions.yaml``).

Disagreements are errors naming both places (``file:line:column``): a HAL arm
whose joints are not the chosen model's (:func:`mission.checks.check_hal_joints`),
and a scenario that simulates another model than the one the mission or the
HAL config names (the controller would drive one arm while the simulator moves
another).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from maris_common.yamlsrc import ConfigIssue, Mark
from sim_backend.platform import scenario_file


@dataclass(frozen=True)
class RigFile:
    """A model or actions file and where it was named: ``origin`` is a phrase for
    messages (``"the HAL config (hal/configs/x.yaml:3:8: model)"``), ``mark`` the place."""

    path: Path
    origin: str
    mark: Mark


def _same(a: Path, b: Path) -> bool:
    try:
        return a.resolve() == b.resolve()
    except OSError:
        return a == b


def hal_rig(hal_config: Any) -> tuple[RigFile | None, RigFile | None]:
    """The model and actions files a HAL config (a :class:`hal.config.HalConfig`) names."""
    out: list[RigFile | None] = []
    for key in ("model", "actions"):
        value = getattr(hal_config, key, None)
        mark = getattr(hal_config, f"{key}_mark", None) or Mark(str(getattr(hal_config, "path", "")), 1, 1)
        out.append(None if not value else RigFile(Path(value), f"the HAL config ({mark}: {key})", mark))
    return out[0], out[1]


def scenario_rig(scenario: Any) -> tuple[RigFile | None, RigFile | None]:
    """The model and actions files a simulator scenario names (``platform.*``).
    ConfigError (at the scenario's line) for a file that does not exist."""
    out: list[RigFile | None] = []
    for key in ("model", "actions"):
        ref = scenario_file(scenario, key)
        out.append(
            None
            if ref is None
            else RigFile(ref.path, f"the scenario `{scenario.name}` ({ref.mark}: platform.{key})", ref.mark)
        )
    return out[0], out[1]


@dataclass(frozen=True)
class Rig:
    """The chosen model and actions (None: the shipped default) and the problems found."""

    model: RigFile | None
    actions: RigFile | None
    issues: tuple[ConfigIssue, ...] = ()


def choose_rig(
    mission_model: RigFile | None,
    mission_actions: RigFile | None,
    hal_config: Any = None,
    scenario: Any = None,
) -> Rig:
    """Apply the precedence of the module docstring; report a scenario that simulates
    another model than the chosen one."""
    hal_model, hal_actions = hal_rig(hal_config) if hal_config is not None else (None, None)
    scen_model, scen_actions = scenario_rig(scenario) if scenario is not None else (None, None)
    model = mission_model or hal_model or scen_model
    actions = mission_actions or hal_actions or scen_actions
    issues = []
    if scen_model is not None and model is not None and not _same(model.path, scen_model.path):
        issues.append(
            ConfigIssue(
                model.mark,
                ("model",),
                f"{model.origin} names the model {model.path.name}, but {scen_model.origin} simulates "
                f"{scen_model.path.name}: the controller would drive one arm while the simulator moves another; "
                "run this mission with a scenario of its rig, or drop one of the two",
            )
        )
    return Rig(model, actions, tuple(issues))
