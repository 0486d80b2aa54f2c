"""Load a mission YAML file into a checked :class:`mission.spec.Mission`.

``load_mission(path, hal_config=None)`` reads the file with
:func:`maris_common.yamlsrc.load_yaml` (safe loading, positions kept), reads
every section, runs the static checks of :mod:`mission.checks`, and raises one
:class:`~maris_common.yamlsrc.ConfigError` listing every problem found
(``file:line:column: field: message``), or returns the mission.
Nothing in a mission file is ever executed.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from hal.config import load_hal_config
from maris_common.yamlsrc import ConfigError, Located, load_yaml, parse_yaml

from . import checks, lint, structure
from . import format as fmt
from .nodes import parse_node
from .platform import RigFile, choose_rig
from .schema import Reader, is_number, type_name
from .spec import BLACKBOARD_TYPES, BlackboardKey, Geofence, Mission, Node, Rates, Safety

FORMAT_VERSION = 1
TOP_KEYS = tuple(fmt.TOP)
DEFAULT_WATCHDOG_S = fmt.DEFAULT_WATCHDOG_S


def load_mission(path: str | Path, hal_config: Any = None, *, strict: bool = False, scenario: Any = None) -> Mission:
    """Load and check the mission at ``path``.

    hal_config: a :class:`hal.config.HalConfig` (anything with ``roles``), a
    path to a HAL config file, or None (device references are then not checked).
    scenario: the simulator scenario of a dry run (:class:`sim_backend.Scenario`),
    or None. ``Mission.model`` / ``actions_file`` are the rig's files: the
    mission's own, else the HAL config's, else the scenario's
    (:mod:`mission.platform`). Raises ConfigError with all problems at once
    (``.warnings`` holds the lint's warnings too). The lint's warnings of a
    mission that loads are in ``Mission.warnings``; ``strict=True`` refuses a
    mission with warnings.
    """
    return build_mission(load_yaml(path), hal_config, strict=strict, scenario=scenario)


def load_mission_text(
    text: str, file: str = "<string>", hal_config: Any = None, base_dir: Path | None = None, *, strict: bool = False
) -> Mission:
    """Like :func:`load_mission` for YAML text (tests, generated missions)."""
    return build_mission(parse_yaml(text, file), hal_config, base_dir=base_dir, text=text, strict=strict)


def build_mission(
    src: Located,
    hal_config: Any = None,
    base_dir: Path | None = None,
    text: str | None = None,
    *,
    strict: bool = False,
    scenario: Any = None,
) -> Mission:
    """Check located YAML data and build the Mission (ConfigError on problems).

    text: unused (key positions come with ``src``), kept for callers."""
    r = Reader(src, text)
    base = base_dir if base_dir is not None else Path(src.file).resolve().parent
    doc = r.mapping(src.data, (), "a mapping with the mission sections (name, safety, tree, abort, ...)")
    if doc is None:
        raise ConfigError(r.issues)
    r.check_keys(doc, (), TOP_KEYS)
    version = r.number(doc, (), "version", default=FORMAT_VERSION, integer=True)
    if version is not None and version != FORMAT_VERSION:
        r.error(("version",), f"unsupported format version {version}; this program reads version {FORMAT_VERSION}")
    name = r.field(doc, (), fmt.TOP["name"]) or "unnamed"
    description = r.field(doc, (), fmt.TOP["description"]) or ""
    model, actions_file, model_origin = _rig(r, src, doc, base, hal_config, scenario)
    rates = _rates(r, doc.get("rates", {}), ("rates",))
    safety = _safety(r, doc, ("safety",))
    blackboard = _blackboard(r, doc.get("blackboard", {}), ("blackboard",))
    tree = _section_node(r, doc, "tree")
    subtrees = _subtrees(r, doc.get("subtrees", {}), ("subtrees",))
    abort = _section_node(
        r,
        doc,
        "abort",
        missing_message=(
            "missing required section `abort`: the tree run on abort or on a safety breach "
            "(e.g. hold still, fold the arm, surface)"
        ),
    )

    hal_roles = checks.hal_roles(r, hal_config, model, model_origin)
    action_names = checks.action_names(r, actions_file, model)
    named_roots = [(section, n) for section, n in (("tree", tree), ("abort", abort)) if n is not None]
    roots = [n for _, n in named_roots]
    graph = structure.check_structure(r, named_roots, subtrees)
    checks.check_tree_references(r, roots, subtrees, blackboard, action_names, hal_roles)
    lint.check_bounded(r, roots, subtrees)
    lint.check_warnings(r, safety, named_roots, subtrees, graph)
    if safety is not None and hal_roles is not None:
        checks.check_watchdogs(r, safety, hal_roles)
    warnings = sorted(r.warnings, key=_position)
    if r.issues or (strict and warnings):
        errors = sorted(r.issues, key=_position)
        raise ConfigError(sorted(errors + warnings, key=_position) if strict else errors, warnings)
    assert tree is not None and abort is not None and safety is not None
    return Mission(
        name=name,
        description=description,
        file=src.file,
        model=model,
        actions_file=actions_file,
        rates=rates,
        safety=safety,
        blackboard=blackboard,
        tree=tree,
        subtrees=subtrees,
        abort=abort,
        action_names=tuple(action_names or ()),
        warnings=tuple(warnings),
    )


def _rig(
    r: Reader, src: Located, doc: dict, base: Path, hal_config: Any, scenario: Any
) -> tuple[Path | None, Path | None, str]:
    """The rig's model and actions file (:mod:`mission.platform`) and a phrase saying
    where the model comes from (for the HAL joints check)."""
    own = []
    for key in ("model", "actions_file"):
        p = _file_ref(r, doc, key, base)
        own.append(None if p is None else RigFile(p, f"the mission ({src.mark((key,))}: {key})", src.mark((key,))))
    if isinstance(hal_config, (str, Path)):
        hal_config = load_hal_config(hal_config)  # ConfigError propagates: its own file's errors
    rig = choose_rig(own[0], own[1], hal_config, scenario)
    r.issues.extend(rig.issues)
    origin = rig.model.origin if rig.model is not None else ""
    return (
        None if rig.model is None else rig.model.path,
        None if rig.actions is None else rig.actions.path,
        origin,
    )


def _position(issue: Any) -> tuple[int, int]:
    return issue.mark.line, issue.mark.column


def _file_ref(r: Reader, doc: dict, key: str, base: Path) -> Path | None:
    value = r.string(doc, (), key, default=None)
    if value is None:
        return None
    p = Path(value)
    p = p if p.is_absolute() else (base / p)
    try:
        found = p.is_file()
    except (OSError, ValueError) as exc:  # name too long, NUL byte, ...
        r.error((key,), f"not a usable file name: {exc.__class__.__name__}: {str(exc)[:80]}")
        return None
    if not found:
        r.error((key,), f"file not found: {p}")
    return p


def _rates(r: Reader, value: Any, path: tuple) -> Rates:
    m = r.mapping(value, path)
    if m is None:
        return Rates()
    r.check_keys(m, path, fmt.RATES)
    tree, vehicle, arm = (r.field(m, path, f) for f in fmt.RATES.values())
    if None not in (tree, vehicle, arm) and not tree <= vehicle <= arm:
        r.error(path, f"rates must satisfy tree_hz <= vehicle_hz <= arm_hz (got {tree:g}, {vehicle:g}, {arm:g})")
    return Rates(tree or 10.0, vehicle or 10.0, arm or 100.0)


def _safety(r: Reader, doc: dict, path: tuple) -> Safety | None:
    if "safety" not in doc:
        r.error(path, "missing required section `safety` (max_depth_m, min_altitude_m, max_duration_s, geofence)")
        return None
    m = r.mapping(doc["safety"], path)
    if m is None:
        return None
    r.check_keys(m, path, fmt.SAFETY)
    max_depth, min_alt, max_dur = (
        r.field(m, path, fmt.SAFETY[k]) for k in ("max_depth_m", "min_altitude_m", "max_duration_s")
    )
    fence = None
    if "geofence" not in m:
        r.error(
            path + ("geofence",),
            "missing required field `geofence` (north_m, east_m, down_m: [low, high] in world NED)",
        )
    else:
        gpath = path + ("geofence",)
        g = r.mapping(m["geofence"], gpath)
        if g is not None:
            r.check_keys(g, gpath, fmt.GEOFENCE)
            n, e, d = (r.interval(g, gpath, k) for k in ("north_m", "east_m", "down_m"))
            if d is not None and max_depth is not None and d[0] >= max_depth:
                r.error(gpath + ("down_m",), f"geofence starts at {d[0]} m, at or below max_depth_m {max_depth}")
            if n and e and d:
                fence = Geofence(n, e, d)
    watchdog = dict(DEFAULT_WATCHDOG_S)
    if "watchdog_s" in m:
        wpath = path + ("watchdog_s",)
        w = r.mapping(m["watchdog_s"], wpath, "a mapping of sensor stream -> timeout in s")
        if w is not None:
            r.check_keys(w, wpath, fmt.WATCHDOG)
            for k in w:
                if k in fmt.WATCHDOG:
                    v = r.field(w, wpath, fmt.WATCHDOG[k])
                    if v is None:
                        watchdog.pop(k, None)
                    else:
                        watchdog[k] = v
    if max_depth is None or min_alt is None or max_dur is None or fence is None:
        return None
    return Safety(max_depth, min_alt, max_dur, fence, watchdog)


def _blackboard(r: Reader, value: Any, path: tuple) -> dict[str, BlackboardKey]:
    m = r.mapping(value, path, "a mapping of key -> value or {type, value}")
    if m is None:
        return {}
    out: dict[str, BlackboardKey] = {}
    for key, entry in m.items():
        kpath = path + (key,)
        if not isinstance(key, str) or not key.isidentifier():
            r.key_error(kpath, f"blackboard key `{key}` must be a name (letters, digits, underscores)")
            continue
        if isinstance(entry, dict):
            r.check_keys(entry, kpath, fmt.BLACKBOARD_ENTRY)
            btype = r.field(entry, kpath, fmt.BLACKBOARD_ENTRY["type"])
            val = entry.get("value")
            if btype is not None and val is not None:
                problem = value_type_problem(btype, val)
                if problem:
                    r.error(kpath + ("value",), problem)
                    r.broken.add(("blackboard", key))
                    continue
                val = coerce_value(btype, val)
            if btype is not None:
                out[key] = BlackboardKey(key, btype, val, r.mark(kpath))
            else:
                r.broken.add(("blackboard", key))
            continue
        btype = infer_type(entry)
        if btype is None:
            r.error(
                kpath,
                f"cannot tell the type of {type_name(entry)} {entry!r}; write {{type: ..., value: ...}} with type one of {', '.join(BLACKBOARD_TYPES)}",
            )
            r.broken.add(("blackboard", key))
            continue
        out[key] = BlackboardKey(key, btype, entry, r.mark(kpath))
    return out


def infer_type(value: Any) -> str | None:
    """Blackboard type of a plain YAML scalar, or None."""
    if isinstance(value, bool):
        return "bool"
    if isinstance(value, int):
        return "int"
    if is_number(value):
        return "float"
    if isinstance(value, str):
        return "str"
    return None


def value_type_problem(btype: str, value: Any) -> str | None:
    """Message if ``value`` does not fit blackboard type ``btype``, else None."""
    ok = {
        "bool": lambda v: isinstance(v, bool),
        "int": lambda v: isinstance(v, int) and not isinstance(v, bool),
        "float": is_number,
        "str": lambda v: isinstance(v, str),
        "point": lambda v: isinstance(v, list) and len(v) == 3 and all(is_number(x) for x in v),
        "pose": lambda v: (
            isinstance(v, list)
            and len(v) == 4
            and all(isinstance(row, list) and len(row) == 4 and all(is_number(x) for x in row) for row in v)
        ),
    }[btype]
    if ok(value):
        return None
    shape = {"point": " ([x, y, z] in m, world NED)", "pose": " (4x4 list of rows, world NED)"}.get(btype, "")
    return f"expected a {btype}{shape}, got {type_name(value)} {value!r}"


def coerce_value(btype: str, value: Any) -> Any:
    """Checked file value -> runtime value (floats; poses/points as nested lists of floats)."""
    if btype == "float":
        return float(value)
    if btype == "point":
        return [float(x) for x in value]
    if btype == "pose":
        return [[float(x) for x in row] for row in value]
    return value


def _section_node(r: Reader, doc: dict, key: str, missing_message: str | None = None) -> Node | None:
    if key not in doc:
        r.error((key,), missing_message or f"missing required section `{key}`")
        return None
    return parse_node(r, doc[key], (key,))


def _subtrees(r: Reader, value: Any, path: tuple) -> dict[str, Node]:
    m = r.mapping(value, path, "a mapping of subtree name -> node")
    if m is None:
        return {}
    out: dict[str, Node] = {}
    for name, body in m.items():
        if not isinstance(name, str) or not name.isidentifier():
            r.key_error(path + (name,), f"subtree name `{name}` must be a name (letters, digits, underscores)")
            continue
        node = parse_node(r, body, path + (name,))
        if node is not None:
            out[name] = node
        else:
            r.broken.add(("subtree", name))
    return out
