"""Static checks of a parsed mission: references and the safety lint.

* References: every ``action.run`` names an action of the actions file; every
  ``subtree.use`` names a subtree (and subtrees do not use themselves); every
  blackboard key used is declared, with a fitting type; with a HAL config,
  every device role a leaf needs is present.
* The safety lint lives in :mod:`mission.lint`, the limits on the trees'
  shape (cycles, depth, size) in :mod:`mission.structure`.

All findings are recorded on the :class:`mission.schema.Reader` as issues.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from behaviours.teleop import DEFAULT_ACTIONS as TELEOP_ACTIONS
from behaviours.teleop import MODE_COMMANDS
from hal.config import load_hal_config
from hal.joints import hal_joint_names, joint_mismatch
from kcl.actions import DEFAULT_ACTIONS, load_actions
from kcl.model import UvmsModel
from maris_common.yamlsrc import ConfigError, ConfigIssue, suggest

from .schema import Reader, is_number
from .spec import WATCHDOG_ROLES, BlackboardKey, Node, Predicate, Safety

#: Device roles needed by each predicate kind.
PREDICATE_ROLES = {
    "detected": ("detector", "vehicle"),
    "grasp_detected": ("gripper",),
    "converged": (),
    "depth_m": ("vehicle",),
    "altitude_m": ("vehicle",),
    "force_n": ("wrench_sensor",),
    "blackboard": (),
}


#: What each operator input can send (mission-level: the drivers behind a role send these):
#: a gamepad and the keyboard velocities only, the Foxglove live view also clicked poses,
#: points and image points (Publish panels).
INPUT_COMMANDS = {
    "gamepad": ("velocity",),
    "foxglove": ("velocity", "pose", "point", "image_point"),
    "keyboard": ("velocity",),
}


def default_actions_file() -> Path:
    """:data:`kcl.actions.DEFAULT_ACTIONS` (imported on call: kcl loads Pinocchio)."""

    return DEFAULT_ACTIONS


_ACTION_CACHE: dict[tuple, list[str]] = {}


def read_action_names(path: Path, model: Path | None = None) -> list[str]:
    """Action names defined in an actions file, via :func:`kcl.actions.load_actions`
    (with the mission's URDF model when given). Raises ConfigError if the file
    (or the model) has problems. Cached on the files' modification times."""
    files = [p for p in (path, model) if p is not None]
    key = tuple((str(p), p.stat().st_mtime_ns) for p in files)
    if key not in _ACTION_CACHE:
        uvms = None
        if model is not None:
            uvms = UvmsModel.load(model)
        _ACTION_CACHE[key] = [str(name) for name in load_actions(path, model=uvms).actions]
    return list(_ACTION_CACHE[key])


def action_names(r: Reader, actions_file: Path | None, model: Path | None) -> list[str] | None:
    """Names the mission's ``run:`` fields may use; None if they cannot be known
    (a missing or broken actions file or model: reported on ``r``)."""

    path = actions_file or default_actions_file()
    if not path.is_file():
        if actions_file is None:
            r.error(("actions_file",), f"the default actions file is missing ({path}): broken installation?")
        return None  # an explicit path was already reported as "file not found"
    if model is not None and not model.is_file():
        return None
    try:
        return read_action_names(path, model)
    except ConfigError as exc:
        for issue in exc.issues:
            r.error(("actions_file",), f"actions file or model has problems: {issue}")
        return None
    except Exception as exc:  # noqa: BLE001 - a broken actions file must not traceback
        r.error(("actions_file",), f"cannot read actions file {path}: {exc}")
        return None


def hal_roles(r: Reader, hal_config: Any, model: Path | None = None, model_origin: str = "") -> frozenset[str] | None:
    """Device roles of the HAL config (object with ``roles``, or a path), or None; also
    checks the HAL arm's joints against the mission's model (default: the shipped URDF;
    ``model_origin``: where it was named, for the message)."""
    if hal_config is None:
        return None
    if isinstance(hal_config, (str, Path)):
        hal_config = load_hal_config(hal_config)  # ConfigError propagates: its own file's errors
    if hasattr(hal_config, "devices"):
        check_hal_joints(r, hal_config, model, model_origin)
    return frozenset(hal_config.roles)


def check_hal_joints(r: Reader, hal_config: Any, model: Path | None, model_origin: str = "") -> None:
    """The HAL arm's joints must be the model's, by name and in order (reported at the
    HAL config's arm, naming where the model was named); configs whose joints come
    from the model (the simulator) pass."""

    names = hal_joint_names(hal_config)
    if names is None or (model is not None and not model.is_file()):
        return

    try:
        uvms = UvmsModel.load(model)
    except ConfigError:
        return  # the model's own problems are reported with the actions file
    name = Path(uvms.urdf_path).name
    label = f"the model {name} named by {model_origin}" if model_origin else f"the default model {name}"
    why = joint_mismatch(names, uvms.joint_names, model=label)
    if why:
        r.issues.append(ConfigIssue(hal_config.devices["arm"].mark, ("devices", "arm", "joints"), why))


# --------------------------------------------------------------------------- references


def check_tree_references(
    r: Reader,
    roots: Iterable[Node],
    subtrees: Mapping[str, Node],
    blackboard: Mapping[str, BlackboardKey],
    actions: Iterable[str] | None,
    roles: frozenset[str] | None,
) -> None:
    """Record issues for dangling references in every tree of the mission."""
    actions = list(actions) if actions is not None else None
    for root in [*roots, *subtrees.values()]:
        for node in root.walk():
            _check_node_refs(r, node, subtrees, blackboard, actions, roles)


def _check_node_refs(r, node: Node, subtrees, blackboard, actions, roles) -> None:
    p = node.params
    if node.kind == "action":
        run = p.get("run")
        if run is not None and actions is not None and run not in actions:
            r.error(
                node.path + ("run",),
                f"unknown action `{run}`{suggest(run, actions)}; the actions file defines: {', '.join(actions)}",
            )
        _need_roles(r, node.path, ("vehicle", "arm"), roles, f"action `{run}`")
        t = p.get("targets") or {}
        _bb_ref(r, node.path + ("targets", "tool_goal_from"), t.get("tool_goal_from"), ("pose",), blackboard)
        _bb_ref(
            r, node.path + ("targets", "camera_target_from"), t.get("camera_target_from"), ("pose", "point"), blackboard
        )
        track = p.get("track_detection")
        if track:
            _bb_ref(r, node.path + ("track_detection", "store_as"), track.get("store_as"), ("pose",), blackboard)
            _need_roles(r, node.path + ("track_detection",), ("detector",), roles, "track_detection")
        if p.get("until") is not None:
            _check_predicate(r, p["until"], blackboard, roles)
    elif node.kind in ("condition", "guard"):
        pred = p.get("predicate") if node.kind == "condition" else p.get("condition")
        if pred is not None:
            _check_predicate(r, pred, blackboard, roles)
            if pred.kind == "converged" and pred.params.get("for_s"):
                r.error(
                    pred.path + ("for_s",),
                    f"`for_s` only works in an action's `until` (a `{node.kind}` checks at once)",
                )
    elif node.kind == "gripper":
        _need_roles(r, node.path, ("gripper",), roles, "gripper command")
    elif node.kind == "teleop":
        _check_teleop(r, node, blackboard, actions, roles)
    elif node.kind == "subtree":
        use = p.get("use")
        if use is not None and use not in subtrees and ("subtree", use) not in r.broken:
            names = ", ".join(subtrees) or "(none defined)"
            r.error(node.path + ("use",), f"unknown subtree `{use}`{suggest(use, list(subtrees))}; subtrees: {names}")
    elif node.kind == "set":
        key = p.get("key")
        if key is not None:
            numeric = ("int", "float") if p.get("add") is not None else None
            entry = _bb_ref(r, node.path + ("key",), key, numeric, blackboard)
            if entry is not None and entry.type == "int" and p.get("add") is not None and p["add"] != int(p["add"]):
                r.error(node.path + ("add",), f"blackboard key `{key}` is an int: add a whole number")
            if entry is not None and not isinstance(p.get("value"), (dict, list)) and p.get("value") is not None:
                problem = _scalar_fits(entry.type, p["value"])
                if problem:
                    r.error(node.path + ("value",), f"blackboard key `{key}` is {_a(entry.type)}: {problem}")


def _check_teleop(r: Reader, node: Node, blackboard, actions, roles) -> None:
    """The actions its modes run exist; its inputs are in the HAL config and can send what
    its modes take; its hand-back condition's references."""
    p = node.params
    modes = tuple(p.get("modes") or ())
    if actions is not None:
        needed = {TELEOP_ACTIONS[m] for m in modes} | {TELEOP_ACTIONS["idle"]}
        if "tool_velocity" in modes:
            needed.add(TELEOP_ACTIONS["tool_velocity/vehicle"])
        missing = sorted(a for a in needed if a not in actions)
        if missing:
            r.error(
                node.path + ("modes",),
                f"the modes need action(s) {', '.join(missing)}, absent from the actions file "
                f"(it defines: {', '.join(actions)})",
            )
    _need_roles(r, node.path, ("vehicle", "arm"), roles, "teleop")
    inputs = tuple(p.get("inputs") or ())
    if roles is not None:
        if inputs:
            _need_roles(r, node.path + ("inputs",), inputs, roles, "teleop")
        elif not any(role in roles for role in INPUT_COMMANDS):
            r.error(
                node.path,
                f"teleop needs an operator input ({', '.join(INPUT_COMMANDS)}), and the HAL config has none",
            )
    listened = inputs or (tuple(role for role in INPUT_COMMANDS if role in roles) if roles is not None else ())
    if listened:
        for i, mode in enumerate(modes):
            if not any(c in INPUT_COMMANDS.get(role, ()) for role in listened for c in MODE_COMMANDS[mode]):
                r.error(
                    node.path + ("modes", i),
                    f"mode `{mode}` takes a {' or '.join(MODE_COMMANDS[mode])}, which none of the inputs "
                    f"({', '.join(listened)}) sends; the foxglove input sends clicked poses and points",
                )
    until = (p.get("handback") or {}).get("until")
    if until is not None:
        _check_predicate(r, until, blackboard, roles)


def _check_predicate(r: Reader, pred: Predicate, blackboard, roles) -> None:
    _need_roles(r, pred.path, PREDICATE_ROLES.get(pred.kind, ()), roles, f"condition `{pred.kind}`")
    if pred.kind == "detected" and pred.params.get("store_as"):
        _bb_ref(r, pred.path + ("store_as",), pred.params["store_as"], ("pose",), blackboard)
    if pred.kind == "blackboard" and pred.params.get("key"):
        op = pred.params.get("op")
        types = ("int", "float") if op in ("below", "above", "at_most", "at_least") else None
        entry = _bb_ref(r, pred.path + ("key",), pred.params["key"], types, blackboard)
        if entry is not None and op in ("equals", "not_equals"):
            problem = _scalar_fits(entry.type, pred.params.get("value"))
            if problem:
                r.error(pred.path + (op,), f"blackboard key `{entry.name}` is {_a(entry.type)}: {problem}")


def _a(word: str) -> str:
    return ("an " if word[0] in "aeiou" else "a ") + word


def _scalar_fits(btype: str, value: Any) -> str | None:
    if btype in ("pose", "point"):
        return f"a {btype} cannot be written or compared from a mission file"
    if btype == "float" and is_number(value):
        return None
    if btype == "int" and isinstance(value, int) and not isinstance(value, bool):
        return None
    if btype == "bool" and isinstance(value, bool):
        return None
    if btype == "str" and isinstance(value, str):
        return None
    return f"value {value!r} is not {_a(btype)}"


def _bb_ref(r: Reader, path: tuple, key: str | None, types: tuple[str, ...] | None, blackboard) -> BlackboardKey | None:
    if key is None or ("blackboard", key) in r.broken:  # a broken declaration was reported already
        return None
    entry = blackboard.get(key)
    if entry is None:
        declared = ", ".join(blackboard) or "(none declared)"
        r.error(
            path,
            f"undeclared blackboard key `{key}`{suggest(key, list(blackboard))}; declare it under `blackboard:` (declared: {declared})",
        )
        return None
    if types is not None and entry.type not in types:
        r.error(path, f"blackboard key `{key}` is {_a(entry.type)}, here {' or '.join(_a(t) for t in types)} is needed")
        return None
    return entry


def _need_roles(r: Reader, path: tuple, needed: Iterable[str], roles: frozenset[str] | None, what: str) -> None:
    if roles is None:
        return
    missing = [role for role in needed if role not in roles]
    if missing:
        r.error(
            path,
            f"{what} needs device role(s) {', '.join(missing)}, absent from the HAL config (it has: {', '.join(sorted(roles))})",
        )


def check_watchdogs(r: Reader, safety: Safety, roles: frozenset[str]) -> None:
    """A watched sensor stream needs its device in the HAL config."""
    for stream in safety.watchdog_s:
        role = WATCHDOG_ROLES[stream]
        if role not in roles:
            r.error(
                ("safety", "watchdog_s", stream), f"watchdog on `{stream}` but the HAL config has no `{role}` device"
            )
