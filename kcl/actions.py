"""Actions of the KCL: one unified task hierarchy and actions as subsets of it,
read from YAML (default ``kcl/data/actions.yaml``; its comments document the
format).

File layout::

    transition_time: 0.5        # s
    regularization: {lam: 1.0e-4, threshold: 1.0e-2}
    postures: {name: [rad x l, null = free], ...}
    hierarchy:                  # highest priority first; one entry = one level
      - {name: joint_limits, type: arm_joint_limits, width: 0.15, ...}
      - level: [ {name: a, type: ...}, {name: b, type: ...} ]   # shared level
        lam: 1.0e-3             # optional per-level regularization
    actions:
      grasp: [joint_limits, ...]

Every problem (unknown key, task type or parameter, bad value, unknown task in
an action, ...) is reported at once as a :class:`ConfigError` with
``file:line:column`` and the field. Nothing is evaluated: YAML safe loading only.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from kcl.model import DATA_DIR, UvmsModel
from kcl.tasks import TASK_TYPES, Task
from maris_common.yamlsrc import ConfigError, ConfigIssue, Located, PathT, load_yaml, parse_yaml, suggest, unknown_keys

DEFAULT_ACTIONS = DATA_DIR / "actions.yaml"
_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_LEVEL_KEYS = ("lam", "threshold")
_TASK_KEYS = ("name", "type", "goal")  # goal: counts for the action's convergence measure


@dataclass(frozen=True)
class PriorityLevel:
    """One level of the unified hierarchy: tasks sharing a priority, stacked.

    ``lam`` / ``threshold``: regularization of this level (None = the file's default).
    """

    name: str
    tasks: tuple[Task, ...]
    lam: float | None = None
    threshold: float | None = None


@dataclass
class ActionSet:
    """The unified hierarchy (``levels``, highest first) and the ``actions``
    (name -> task names in priority order). ``postures``: named arm postures (rad)."""

    model: UvmsModel
    levels: tuple[PriorityLevel, ...]
    actions: dict[str, tuple[str, ...]]
    transition_time: float = 0.5
    lam: float = 1e-4
    threshold: float = 1e-2
    postures: dict[str, tuple[float | None, ...]] = field(default_factory=dict)
    source: str = ""

    def __post_init__(self) -> None:
        self.tasks: dict[str, Task] = {t.name: t for lv in self.levels for t in lv.tasks}
        self.level_of: dict[str, int] = {t.name: k for k, lv in enumerate(self.levels) for t in lv.tasks}

    def tasks_of(self, action: str) -> tuple[str, ...]:
        """Task names of ``action``, highest priority first (KeyError if unknown)."""
        if action not in self.actions:
            raise KeyError(
                f"unknown action `{action}`{suggest(action, self.actions)}; known: {', '.join(self.actions)}"
            )
        return self.actions[action]


def load_actions(path: str | Path | None = None, model: UvmsModel | None = None) -> ActionSet:
    """Read an actions file (None: the shipped default) for ``model`` (None: the
    default UVMS). Raises :class:`ConfigError` listing every problem."""
    src = load_yaml(path if path is not None else DEFAULT_ACTIONS)
    return build_actions(src, model if model is not None else UvmsModel.load())


def parse_actions(text: str, model: UvmsModel | None = None, file: str = "<string>") -> ActionSet:
    """Like :func:`load_actions` for YAML text (tests, generated files)."""
    return build_actions(parse_yaml(text, file), model if model is not None else UvmsModel.load())


# ---------------------------------------------------------------------------- checks


def _number(src: Located, path: PathT, value: Any, kind: str, issues: list[ConfigIssue]) -> float | None:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        issues.append(src.issue(path, f"expected a number, got {value!r}"))
        return None
    v = float(value)
    if not math.isfinite(v) and not (kind == "positive" and v == math.inf):
        issues.append(src.issue(path, f"expected a finite number, got {value!r}"))
        return None
    if kind == "positive" and v <= 0:
        issues.append(src.issue(path, f"must be > 0, got {value!r}"))
        return None
    if kind == "nonneg" and v < 0:
        issues.append(src.issue(path, f"must be >= 0, got {value!r}"))
        return None
    return v


def _posture(
    src: Located, path: PathT, value: Any, l: int, issues: list[ConfigIssue]
) -> tuple[float | None, ...] | None:
    if not isinstance(value, list):
        issues.append(src.issue(path, f"expected a list of {l} joint angles (rad, null = free)"))
        return None
    if len(value) != l:
        issues.append(src.issue(path, f"expected {l} entries (one per arm joint), got {len(value)}"))
        return None
    out: list[float | None] = []
    ok = True
    for i, v in enumerate(value):
        if v is None:
            out.append(None)
            continue
        num = _number(src, path + (i,), v, "any", issues)
        ok &= num is not None
        out.append(num)
    return tuple(out) if ok else None


def _build_task(
    src: Located, path: PathT, entry: Any, model: UvmsModel, postures: dict, issues: list[ConfigIssue]
) -> Task | None:
    if not isinstance(entry, dict):
        issues.append(src.issue(path, "expected a task mapping with `name` and `type`"))
        return None
    name, ttype = entry.get("name"), entry.get("type")
    ok = True
    if not isinstance(name, str) or not _NAME.match(name):
        issues.append(src.issue(path + ("name",), f"task needs a `name` made of letters, digits and _ (got {name!r})"))
        ok = False
    if ttype not in TASK_TYPES:
        issues.append(
            src.issue(
                path + ("type",),
                f"unknown task type {ttype!r}{suggest(str(ttype), TASK_TYPES)}; known: {', '.join(TASK_TYPES)}",
            )
        )
        return None
    cls = TASK_TYPES[ttype]
    allowed = (*_TASK_KEYS, *_LEVEL_KEYS, *cls.PARAMS)
    goal = entry.get("goal", cls.KIND == "equality")
    if not isinstance(goal, bool):
        issues.append(src.issue(path + ("goal",), f"expected true or false, got {goal!r}"))
        ok = False
    bad = unknown_keys(src, entry, path, allowed)
    issues.extend(bad)
    ok &= not bad
    params: dict[str, Any] = {}
    for key, spec in cls.PARAMS.items():
        if key not in entry:
            if spec.default is None:
                issues.append(src.issue(path, f"task `{name}` ({ttype}) needs `{key}`: {spec.doc}"))
                ok = False
            continue
        value, vpath = entry[key], path + (key,)
        v: Any
        if spec.kind in ("positive", "nonneg", "any"):
            v = _number(src, vpath, value, spec.kind, issues)
        elif spec.kind == "posture":
            if isinstance(value, str):
                v = postures.get(value)
                if v is None:
                    issues.append(
                        src.issue(
                            vpath,
                            f"unknown posture `{value}`{suggest(value, postures)}; defined: {', '.join(postures) or 'none'}",
                        )
                    )
            else:
                v = _posture(src, vpath, value, model.n_joints, issues)
        elif spec.kind == "frame":
            v = (
                value
                if isinstance(value, str) and (value in model.frames or model.pin_model.existFrame(value))
                else None
            )
            if v is None:
                issues.append(
                    src.issue(
                        vpath,
                        f"unknown frame {value!r}{suggest(str(value), model.frames)}; roles: {', '.join(model.frames)}",
                    )
                )
        elif spec.kind == "bool":
            v = value if isinstance(value, bool) else None
            if v is None:
                issues.append(src.issue(vpath, f"expected true or false, got {value!r}"))
        else:  # pragma: no cover - a task declared an unknown kind
            raise TypeError(f"{cls.__name__}.PARAMS[{key!r}]: unknown kind {spec.kind!r}")
        if v is None:
            ok = False
        else:
            params[key] = list(v) if spec.kind == "posture" else v
    if not ok:
        return None
    try:
        task = cls(str(name), model, **params)
        task.is_goal = goal
        return task
    except (ValueError, TypeError) as exc:
        issues.append(src.issue(path, f"task `{name}` ({ttype}): {exc}"))
        return None


def _level_settings(
    src: Located, path: PathT, entry: dict, issues: list[ConfigIssue]
) -> tuple[float | None, float | None]:
    lam = _number(src, path + ("lam",), entry["lam"], "nonneg", issues) if "lam" in entry else None
    th = _number(src, path + ("threshold",), entry["threshold"], "positive", issues) if "threshold" in entry else None
    return lam, th


def _all_task_entries(hierarchy: list) -> list[tuple[int, dict]]:
    out = []
    for k, entry in enumerate(hierarchy):
        if isinstance(entry, dict) and isinstance(entry.get("level"), list):
            out += [(k, e) for e in entry["level"] if isinstance(e, dict)]
        elif isinstance(entry, dict):
            out.append((k, entry))
    return out


def build_actions(src: Located, model: UvmsModel) -> ActionSet:
    """Check and build an :class:`ActionSet` from parsed YAML."""
    issues: list[ConfigIssue] = []
    data = src.data
    if not isinstance(data, dict):
        raise ConfigError([src.issue((), "expected a mapping with `hierarchy` and `actions`")])
    issues += unknown_keys(src, data, (), ("transition_time", "regularization", "postures", "hierarchy", "actions"))

    transition_time = 0.5
    if "transition_time" in data:
        v = _number(src, ("transition_time",), data["transition_time"], "nonneg", issues)
        transition_time = v if v is not None else transition_time
    lam, threshold = 1e-4, 1e-2
    reg = data.get("regularization", {})
    if not isinstance(reg, dict):
        issues.append(src.issue(("regularization",), "expected a mapping with `lam` and `threshold`"))
    else:
        issues += unknown_keys(src, reg, ("regularization",), _LEVEL_KEYS)
        rl, rt = _level_settings(src, ("regularization",), reg, issues)
        lam = rl if rl is not None else lam
        threshold = rt if rt is not None else threshold

    postures: dict[str, tuple[float | None, ...]] = {}
    raw_postures = data.get("postures", {})
    if not isinstance(raw_postures, dict):
        issues.append(src.issue(("postures",), "expected a mapping name -> list of joint angles"))
    else:
        for pname, value in raw_postures.items():
            p = _posture(src, ("postures", pname), value, model.n_joints, issues)
            if p is not None:
                postures[str(pname)] = p

    levels: list[PriorityLevel] = []
    seen: dict[str, PathT] = {}
    hierarchy = data.get("hierarchy")
    if not isinstance(hierarchy, list) or not hierarchy:
        issues.append(src.issue(("hierarchy",), "expected a non-empty list of priority levels (highest first)"))
        hierarchy = []
    for k, entry in enumerate(hierarchy):
        path: PathT = ("hierarchy", k)
        if isinstance(entry, dict) and "level" in entry:
            issues += unknown_keys(src, entry, path, ("level", *_LEVEL_KEYS))
            members = entry["level"]
            if not isinstance(members, list) or not members:
                issues.append(src.issue(path + ("level",), "expected a non-empty list of tasks sharing this level"))
                continue
            task_paths = [(path + ("level", i), e) for i, e in enumerate(members)]
        else:
            task_paths = [(path, entry)]
        lam_k, th_k = _level_settings(src, path, entry, issues) if isinstance(entry, dict) else (None, None)
        tasks: list[Task] = []
        for tpath, tentry in task_paths:
            task = _build_task(src, tpath, tentry, model, postures, issues)
            if task is None:
                continue
            if task.name in seen:
                issues.append(src.issue(tpath + ("name",), f"duplicate task name `{task.name}`"))
                continue
            seen[task.name] = tpath
            tasks.append(task)
        if tasks:
            levels.append(PriorityLevel("+".join(t.name for t in tasks), tuple(tasks), lam_k, th_k))

    declared = list(seen) + [str(e.get("name")) for _, e in _all_task_entries(hierarchy)]
    actions: dict[str, tuple[str, ...]] = {}
    raw_actions = data.get("actions")
    if not isinstance(raw_actions, dict) or not raw_actions:
        issues.append(src.issue(("actions",), "expected a mapping action name -> list of task names"))
        raw_actions = {}
    for aname, members in raw_actions.items():
        apath: PathT = ("actions", aname)
        if not isinstance(aname, str) or not _NAME.match(aname):
            issues.append(src.issue(apath, f"bad action name {aname!r}"))
            continue
        if not isinstance(members, list) or not members:
            issues.append(src.issue(apath, "expected a non-empty list of task names"))
            continue
        names: list[str] = []
        for i, tname in enumerate(members):
            if not isinstance(tname, str) or tname not in seen:
                if tname not in declared:  # a declared task that failed was reported already
                    issues.append(src.issue(apath + (i,), f"unknown task `{tname}`{suggest(str(tname), declared)}"))
                continue
            if tname in names:
                issues.append(src.issue(apath + (i,), f"task `{tname}` listed twice"))
                continue
            names.append(tname)
        order = {name: idx for idx, name in enumerate(seen)}
        actions[aname] = tuple(sorted(names, key=lambda n: order[n]))

    if issues:
        raise ConfigError(issues)
    return ActionSet(model, tuple(levels), actions, transition_time, lam, threshold, postures, src.file)
