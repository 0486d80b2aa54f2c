"""Rebuild what a run was made of from its own log, for a replay.

The mission, actions and model files are taken from ``/run/source`` (their
text as the run read it, not whatever is on disk today) and written under a
work folder at their original absolute paths (``<work>/sources/<path>``), so
the mission's relative references resolve to the logged copies. The
controller settings and the supervisor options come from ``/run/config``; the
device roles the mission is checked against are the logged devices'.

A what-if replaces the mission (``--mission``, read from disk with its own
actions and model) or controller settings (``--set``); the base rate must stay
the log's, since the replay serves the inputs step by step.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mission.loader import load_mission
from mission.logs.runmeta import cpu_description, versions
from mission.replay.record import code_fingerprint
from mission.replay.serve import NotReplayable, ReplayInputs
from mission.replay.settings import NO_FILTER_CUTOFF_RAD_S
from mission.runtime.api import RunOptions
from mission.runtime.result import SupervisorOptions
from mission.spec import DeviceRoles, Mission

#: Logged controller fields passed on as they were (the rates and actuated DOFs
#: are derived again by :func:`mission.runtime.api.run_mission`).
CONTROLLER_FIELDS = ("vehicle_velocity_limit", "joint_velocity_limit", "lam", "threshold", "eta")


@dataclass
class ReplaySetup:
    """Everything :func:`mission.runtime.api.run_mission` needs to rerun the log."""

    mission: Mission
    #: The logged devices' roles (the mission is checked against them).
    roles: DeviceRoles
    #: The logged run's controller settings and supervisor options, with the what-if
    #: changes (no log path: the replay chooses its own).
    options: RunOptions
    #: What differs from the logged run (empty: an exact replay).
    changes: list[str] = field(default_factory=list)
    #: Remarks for the user (e.g. settings the log did not have).
    notes: list[str] = field(default_factory=list)
    #: The log was written by other code than this (its source fingerprint differs).
    other_code: bool = False


def _tuple(v: Any) -> Any:
    return tuple(v) if isinstance(v, list) else v


def _shown(name: str, value: Any) -> str:
    if name == "filter_cutoff_rad_s" and value is not None and value >= NO_FILTER_CUTOFF_RAD_S:
        return "off (no filter)"
    return repr(value)


def write_sources(log: Any, inputs: ReplayInputs, work: Path) -> dict[str, Path]:
    """Write every ``/run/source`` file under ``work/sources`` at its absolute path; role -> copy."""
    out: dict[str, Path] = {}
    root = work / "sources"
    for msg in log.messages("/run/source"):
        role, text = msg.get("role"), msg.get("text")
        if not isinstance(role, str) or not isinstance(text, str):
            continue
        original = Path(inputs.header.get("mission_file") or msg["path"]) if role == "mission" else Path(msg["path"])
        if not original.is_absolute():
            original = Path.cwd() / original
        dest = root / original.relative_to(original.anchor)
        dest.parent.mkdir(parents=True, exist_ok=True)
        dest.write_text(text, encoding="utf-8")
        out[role] = dest
    return out


def software_differences(log: Any, inputs: ReplayInputs) -> list[str]:
    """What differs between the software that wrote the log and this one (versions
    from the log's ``maris.run`` metadata): a divergence may
    come from there rather than from the inputs."""

    notes = []
    code = inputs.header.get("code")
    if code is not None and code != code_fingerprint():
        notes.append(
            f"the log was written by other code (source fingerprint {code}, this one {code_fingerprint()}): "
            "differences may come from the code, not the inputs"
        )
    meta = getattr(log, "metadata", {}).get("maris.run", {})
    now = versions()
    changed = [
        f"{name} {meta['version.' + name]} -> {v}"
        for name, v in now.items()
        if meta.get("version." + name) not in (None, v)
    ]
    if changed:
        notes.append(
            "the log was written by other software versions (" + ", ".join(changed) + "): differences may "
            "come from the code, not the inputs"
        )
    cpu, here = meta.get("cpu"), cpu_description()
    if cpu is None:
        notes.append(
            f"the log does not say which CPU wrote it (older code); if not this one ({here}), numpy, OpenBLAS "
            "and Numba may round the last bit differently: compare with --tolerance 1e-9 (docs/replay.md)"
        )
    elif cpu != here:
        notes.append(
            f"the log was written on another CPU ({cpu}; this one: {here}): numpy, OpenBLAS and Numba may "
            "round the last bit differently there, compare with --tolerance 1e-9 (docs/replay.md)"
        )
    return notes


def setup_replay(
    log: Any,
    inputs: ReplayInputs,
    work: Path,
    *,
    mission_path: str | Path | None = None,
    settings: dict[str, Any] | None = None,
) -> ReplaySetup:
    """Mission, controller settings and supervisor options of the logged run, with
    the what-if changes. Raises :class:`NotReplayable` (nothing to rebuild from)
    or :class:`maris_common.yamlsrc.ConfigError` (a changed mission is invalid)."""

    configs = log.messages("/run/config")
    if not configs:
        raise NotReplayable(f"{log.path} has no /run/config: not a run log")
    config = configs[0]
    sources = write_sources(log, inputs, work)
    roles = DeviceRoles(frozenset(d["role"] for d in inputs.header.get("devices", ())))
    changes: list[str] = []
    notes: list[str] = []
    if mission_path is None:
        if "mission" not in sources:
            raise NotReplayable(f"{log.path} does not hold the mission's text (/run/source): nothing to rebuild")
        mission = load_mission(sources["mission"], roles)
        # the actions and model the run used, whatever the mission's references resolve to now
        mission = dataclasses.replace(
            mission,
            model=sources.get("model", mission.model),
            actions_file=sources.get("actions", mission.actions_file),
        )
    else:
        mission = load_mission(mission_path, roles)
        changes.append(f"mission {mission_path}")
    dts = {float(m["dt"]) for m in inputs.steps.values() if "dt" in m}
    if dts and not any(abs(1.0 / mission.rates.arm_hz - dt) <= 1e-12 for dt in dts):
        raise NotReplayable(
            f"the mission's base rate (rates.arm_hz = {mission.rates.arm_hz:g}) differs from the "
            f"log's ({1.0 / min(dts):g} Hz): a replay serves the inputs step by step, keep arm_hz"
        )
    logged = config.get("controller") or {}
    filter_cutoff = float(logged.get("filter_cutoff_rad_s", 50.0))
    compensation = bool(logged.get("compensation", True))
    opts = {k: _tuple(logged[k]) for k in CONTROLLER_FIELDS if k in logged}
    for name, value in (settings or {}).items():
        before = {"filter_cutoff_rad_s": filter_cutoff, "compensation": compensation}.get(name, opts.get(name))
        if name == "filter_cutoff_rad_s":
            filter_cutoff = value
        elif name == "compensation":
            compensation = value
        else:
            opts[name] = value
        changes.append(f"controller.{name}: {_shown(name, before)} -> {_shown(name, value)}")
    known = {f.name for f in dataclasses.fields(SupervisorOptions)}
    sup = config.get("supervisor") or {}
    unknown = sorted(set(sup) - known)
    if unknown:
        notes.append(f"supervisor options this version does not have were ignored: {', '.join(unknown)}")
    supervisor = SupervisorOptions(**{k: v for k, v in sup.items() if k in known and k != "raise_internal_errors"})
    notes += software_differences(log, inputs)
    options = RunOptions(
        filter_cutoff=filter_cutoff, compensation=compensation, controller_options=opts, supervisor=supervisor
    )
    code = inputs.header.get("code")
    return ReplaySetup(
        mission=mission,
        roles=roles,
        options=options,
        changes=changes,
        notes=notes,
        other_code=code is not None and code != code_fingerprint(),
    )
