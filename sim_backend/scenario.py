"""Scenario files: load, validate, override, and sample them.

A scenario is a YAML file in ``sim_backend/scenarios/`` (or any path). It may
start from another scenario with ``extends: <name>`` and then set only what
differs. Every value is checked against :mod:`sim_backend.schema`; all problems
are reported at once as a :class:`~maris_common.yamlsrc.ConfigError` naming
``file:line:column`` and the field.

:class:`Scenario` holds the validated values (flat, dotted keys), still with
their random ranges; :func:`sample_values` draws one concrete set from a seeded
generator. Scenarios are plain frozen data and pickle fine (campaigns send them
to worker processes).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from maris_common.yamlsrc import ConfigError, ConfigIssue, Located, Mark, load_yaml, suggest

from .rng import child_rng
from .schema import PARAMS_BY_KEY, SECTIONS, TURBIDITY_LEVELS, Param
from .schema_ardusub import ardusub_cross_checks
from .schema_dynamics import VEHICLE_MODELS

SCENARIO_DIR = Path(__file__).parent / "scenarios"


@dataclass(frozen=True)
class Range:
    """A number drawn uniformly in [lo, hi] from the run's seed."""

    lo: float
    hi: float


@dataclass(frozen=True)
class Choice:
    """A value drawn with equal probability among ``options``."""

    options: tuple[Any, ...]


@dataclass(frozen=True)
class Scenario:
    """Validated scenario: ``values`` maps every dotted parameter name to its value
    (defaults filled in; :class:`Range` / :class:`Choice` where randomized)."""

    name: str
    source: str
    values: Mapping[str, Any] = field(default_factory=dict)

    def __getitem__(self, key: str) -> Any:
        return self.values[key]

    @property
    def randomized(self) -> bool:
        """True if any value is drawn from the seed."""
        return any(isinstance(v, (Range, Choice)) for v in self.values.values())


def available_scenarios() -> list[str]:
    """Names of the shipped scenarios (file stems)."""
    return sorted(p.stem for p in SCENARIO_DIR.glob("*.yaml"))


def _resolve_path(name_or_path: str | Path) -> Path:
    p = Path(name_or_path)
    if p.suffix in (".yaml", ".yml") or len(p.parts) > 1:
        return p
    candidate = SCENARIO_DIR / f"{p.name}.yaml"
    if not candidate.exists():
        names = available_scenarios()
        raise ConfigError(
            [
                ConfigIssue(
                    Mark(str(name_or_path), 1, 1),
                    (),
                    f"no scenario named `{p.name}`{suggest(p.name, names)}; shipped: {', '.join(names)}",
                )
            ]
        )
    return candidate


# --------------------------------------------------------------------------- validation


def _is_number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(float(x))


def _check_number(x: Any, p: Param, what: str = "") -> str | None:
    if not _is_number(x):
        return f"{what}expected a finite number, got {x!r}"
    if not (p.lo <= float(x) <= p.hi):
        return f"{what}{x!r} is outside [{p.lo:g}, {p.hi:g}]" + (f" ({p.unit})" if p.unit else "")
    return None


def _validate(p: Param, raw: Any) -> tuple[Any, str | None]:
    """Return ``(value, error)`` for the raw YAML value of parameter ``p``."""
    k = p.kind
    if k == "float":
        err = _check_number(raw, p)
        return (float(raw) if err is None else None), err
    if k == "range":
        if isinstance(raw, dict):
            if set(raw) != {"min", "max"}:
                return None, f"a range is `{{min: a, max: b}}`, got keys {sorted(map(str, raw))}"
            err = _check_number(raw["min"], p, "min: ") or _check_number(raw["max"], p, "max: ")
            if err:
                return None, err
            lo, hi = float(raw["min"]), float(raw["max"])
            if lo > hi:
                return None, f"min ({lo:g}) is greater than max ({hi:g})"
            return (lo if lo == hi else Range(lo, hi)), None
        err = _check_number(raw, p)
        return (float(raw) if err is None else None), err
    if k == "int":
        if not isinstance(raw, int) or isinstance(raw, bool):
            return None, f"expected an integer, got {raw!r}"
        return raw, None
    if k == "bool":
        if not isinstance(raw, bool):
            return None, f"expected true or false, got {raw!r}"
        return raw, None
    if k == "str":
        if not isinstance(raw, str):
            return None, f"expected text, got {raw!r}"
        return raw, None
    if k in ("vec", "bools"):
        if not isinstance(raw, list) or len(raw) != p.n:
            return None, f"expected a list of {p.n} {'numbers' if k == 'vec' else 'booleans'}, got {raw!r}"
        if k == "bools":
            if not all(isinstance(b, bool) for b in raw):
                return None, f"expected a list of {p.n} booleans, got {raw!r}"
            return tuple(raw), None
        for i, x in enumerate(raw):
            err = _check_number(x, p, f"item {i}: ")
            if err:
                return None, err
        return tuple(float(x) for x in raw), None
    if k == "floats_or_null":
        if raw is None:
            return None, None
        if not isinstance(raw, list) or not all(_is_number(x) for x in raw):
            return None, f"expected null or a list of numbers, got {raw!r}"
        return tuple(float(x) for x in raw), None
    if k == "intervals":
        if not isinstance(raw, list):
            return None, f"expected a list of [t_start, t_end] pairs, got {raw!r}"
        out = []
        for i, pair in enumerate(raw):
            if not (isinstance(pair, list) and len(pair) == 2 and all(_is_number(x) for x in pair)):
                return None, f"item {i}: expected [t_start, t_end] in s, got {pair!r}"
            if pair[0] > pair[1]:
                return None, f"item {i}: t_start {pair[0]} is after t_end {pair[1]}"
            out.append((float(pair[0]), float(pair[1])))
        return tuple(out), None
    if k == "turbidity":
        levels = ", ".join(TURBIDITY_LEVELS)
        if isinstance(raw, dict):
            opts = raw.get("choice")
            if set(raw) != {"choice"} or not isinstance(opts, list) or not opts:
                return None, "a random turbidity is `{choice: [clear, slightly_turbid, ...]}`"
            bad = [o for o in opts if o not in TURBIDITY_LEVELS]
            if bad:
                return None, f"unknown turbidity {bad[0]!r}{suggest(str(bad[0]), TURBIDITY_LEVELS)}; levels: {levels}"
            return (opts[0] if len(opts) == 1 else Choice(tuple(opts))), None
        if raw not in TURBIDITY_LEVELS:
            return None, f"unknown turbidity {raw!r}{suggest(str(raw), TURBIDITY_LEVELS)}; levels: {levels}"
        return raw, None
    if k == "per_turbidity":
        if not isinstance(raw, dict) or set(raw) != set(TURBIDITY_LEVELS):
            return None, f"expected one number for each of: {', '.join(TURBIDITY_LEVELS)}"
        for lvl in TURBIDITY_LEVELS:
            err = _check_number(raw[lvl], p, f"{lvl}: ")
            if err:
                return None, err
        return {lvl: float(raw[lvl]) for lvl in TURBIDITY_LEVELS}, None
    raise AssertionError(f"unknown parameter kind {k}")  # schema bug, not user input


def _cross_checks(values: dict[str, Any]) -> list[tuple[str, str]]:
    """Consistency between parameters: ``(key, message)`` pairs."""
    out = []

    if values["vehicle.model"] not in VEHICLE_MODELS:
        out.append(
            (
                "vehicle.model",
                f"unknown vehicle model {values['vehicle.model']!r}"
                f"{suggest(str(values['vehicle.model']), VEHICLE_MODELS)}; models: {', '.join(VEHICLE_MODELS)}",
            )
        )
    if values["thrusters.max_reverse_n"] > values["thrusters.max_forward_n"] * 2:
        out.append(("thrusters.max_reverse_n", "more than twice the forward thrust: check the units (N)"))
    if values["vision.min_range_m"] >= values["vision.max_range_m"]:
        out.append(("vision.min_range_m", "must be smaller than vision.max_range_m"))
    if values["dvl.min_altitude_m"] >= values["dvl.max_altitude_m"]:
        out.append(("dvl.min_altitude_m", "must be smaller than dvl.max_altitude_m"))
    size = values["pool.size_m"]
    for key, axis in (
        ("pipe.x_m", 0),
        ("pipe.y_m", 1),
        ("vehicle.start_x_m", 0),
        ("vehicle.start_y_m", 1),
        ("vehicle.start_z_m", 2),
    ):
        v = values[key]
        lo, hi = (v.lo, v.hi) if isinstance(v, Range) else (v, v)
        if lo < 0.0 or hi > size[axis]:
            out.append((key, f"must lie inside the pool: [0, {size[axis]:g}] m (pool.size_m)"))
    fh = values["pipe.float_height_m"]
    if (fh.hi if isinstance(fh, Range) else fh) + 2 * values["pipe.radius_m"] > size[2]:
        out.append(("pipe.float_height_m", "the pipe would stick out of the water (pool.size_m depth)"))
    out.extend(ardusub_cross_checks(values))
    return out


def _read_layers(path: Path, seen: tuple[str, ...]) -> list[tuple[Located, dict]]:
    """The file and the files it extends, base first."""
    src = load_yaml(path)
    data = src.data
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError([src.issue((), "a scenario file is a mapping of sections (pool:, vehicle:, dvl:, ...)")])
    layers: list[tuple[Located, dict]] = []
    base = data.get("extends")
    if base is not None:
        if not isinstance(base, str):
            raise ConfigError([src.issue(("extends",), "expected the name of a scenario")])
        if base in seen:
            raise ConfigError([src.issue(("extends",), f"circular `extends`: {' -> '.join(seen + (base,))}")])
        try:
            base_path = _resolve_path(base)
        except ConfigError as exc:
            raise ConfigError([src.issue(("extends",), exc.issues[0].message)]) from None
        layers = _read_layers(base_path, seen + (base,))
    layers.append((src, data))
    return layers


def _apply_layer(
    src: Located, data: dict, values: dict[str, Any], issues: list[ConfigIssue], origin: dict[str, Located]
) -> None:
    for section, body in data.items():
        if section in ("extends", "description"):
            if section == "description":
                v, err = _validate(PARAMS_BY_KEY["description"], body)
                if err:
                    issues.append(src.issue((section,), err))
                else:
                    values["description"] = v
            continue
        if section not in SECTIONS:
            allowed = list(SECTIONS) + ["extends", "description"]
            issues.append(
                src.issue(
                    (section,), f"unknown section `{section}`{suggest(section, allowed)}; allowed: {', '.join(allowed)}"
                )
            )
            continue
        if not isinstance(body, dict):
            issues.append(src.issue((section,), "expected a mapping of parameters"))
            continue
        keys = [k.split(".", 1)[1] for k in PARAMS_BY_KEY if k.startswith(section + ".")]
        for key, raw in body.items():
            p = PARAMS_BY_KEY.get(f"{section}.{key}")
            if p is None:
                issues.append(
                    src.issue(
                        (section, key),
                        f"unknown parameter `{key}`{suggest(str(key), keys)}; allowed: {', '.join(keys)}",
                    )
                )
                continue
            if p.kind == "per_turbidity" and isinstance(raw, dict):
                bad = [lvl for lvl in raw if lvl not in TURBIDITY_LEVELS]
                if bad:
                    issues.append(
                        src.issue(
                            (section, key, bad[0]),
                            f"unknown turbidity `{bad[0]}`{suggest(str(bad[0]), TURBIDITY_LEVELS)}",
                        )
                    )
                    continue
                raw = {**values[p.key], **raw}  # levels not written keep their value
            v, err = _validate(p, raw)
            if err:
                issues.append(src.issue((section, key), err))
            else:
                values[p.key] = v
                origin[p.key] = src


def _parse_override(raw: Any) -> Any:
    """Overrides from a command line arrive as text: read them as YAML scalars/lists."""
    if isinstance(raw, str):
        try:
            return yaml.safe_load(raw)
        except yaml.YAMLError:
            return raw
    if isinstance(raw, tuple):
        return [_parse_override(x) for x in raw]
    return raw


def load_scenario(name_or_path: str | Path, overrides: dict[str, Any] | None = None) -> Scenario:
    """Load a scenario by name (file stem in ``sim_backend/scenarios/``) or path.

    ``overrides`` maps dotted names to values, e.g. ``{"dvl.noise_std_mps": 0.02}``,
    ``{"pipe.x_m": {"min": 10, "max": 14}}`` or one level of a per-turbidity table
    ``{"vision.detection_probability.clear": 0.8}``; text values are read as YAML.
    Raises ConfigError (all problems at once) for unknown or invalid fields.
    """
    path = _resolve_path(name_or_path)
    layers = _read_layers(path, (path.stem,))
    values: dict[str, Any] = {p.key: p.default for p in PARAMS_BY_KEY.values()}
    issues: list[ConfigIssue] = []
    origin: dict[str, Located] = {}  # which file set each key (for cross-check marks)
    for src, data in layers:
        _apply_layer(src, data, values, issues, origin)
    for key, raw in (overrides or {}).items():
        mark = Mark("<override>", 1, 1)
        head, _, level = key.rpartition(".")
        if key not in PARAMS_BY_KEY and head in PARAMS_BY_KEY and PARAMS_BY_KEY[head].kind == "per_turbidity":
            # one level of a per-turbidity table, e.g. "vision.detection_probability.clear"
            if level not in TURBIDITY_LEVELS:
                issues.append(
                    ConfigIssue(mark, (key,), f"unknown turbidity `{level}`{suggest(level, TURBIDITY_LEVELS)}")
                )
                continue
            key, raw = head, {**values[head], level: _parse_override(raw)}
        p = PARAMS_BY_KEY.get(key)
        if p is None:
            issues.append(ConfigIssue(mark, (key,), f"unknown scenario parameter{suggest(key, PARAMS_BY_KEY)}"))
            continue
        v, err = _validate(p, _parse_override(raw))
        if err:
            issues.append(ConfigIssue(mark, (key,), err))
        else:
            values[key] = v
            origin.pop(key, None)
    if not issues:
        for key, msg in _cross_checks(values):
            section, sub = key.split(".", 1)
            layer = origin.get(key)
            if layer is not None:
                issues.append(layer.issue((section, sub), msg))
            else:  # an override or a default
                issues.append(
                    ConfigIssue(
                        Mark("<override>" if key in (overrides or {}) else str(path), 1, 1), (section, sub), msg
                    )
                )
    if issues:
        raise ConfigError(issues)
    return Scenario(name=path.stem, source=str(path), values=values)


def sample_values(scenario: Scenario, seed: int) -> dict[str, Any]:
    """Concrete parameter values for run ``seed``: each range or choice is drawn
    from its own stream (named after the parameter), so a given seed always gives
    the same draw and adding a random parameter never changes the others.
    A seed that is not a non-negative integer is a ConfigError."""
    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or seed < 0:
        raise ConfigError(
            [ConfigIssue(Mark("<seed>", 1, 1), ("seed",), f"must be a non-negative integer, got {seed!r}")]
        )
    out: dict[str, Any] = {}
    for key, v in scenario.values.items():
        rng = child_rng(seed, "scenario", key) if isinstance(v, (Range, Choice)) else None
        if isinstance(v, Range):
            out[key] = float(rng.uniform(v.lo, v.hi))
        elif isinstance(v, Choice):
            out[key] = v.options[int(rng.integers(len(v.options)))]
        else:
            out[key] = v
    return out
