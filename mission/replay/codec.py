"""Device readings <-> input records (JSON), exactly.

Encoding goes through orjson, whose float output is the shortest text that
reads back to the same double: a decoded value is bit for bit the one the
device returned (including ``-0.0``). Arrays are written as float64 (a float32
array would otherwise come back as a different double). NaN and the
infinities, which strict JSON cannot hold, are written as ``null`` and named in
the record's ``nonfinite`` list (``"attitude.1=nan"``; arrays by flat index).
Absent optional values (no DVL velocity, unknown altitude) are left out; a
detection's 4x4 pose is written row major (16 numbers).

Units and frames are those of :mod:`hal.interfaces`.
"""

from __future__ import annotations

import builtins
import importlib
import math
from typing import Any

import numpy as np
import orjson

from hal.interfaces import (
    Detection,
    GripperMotion,
    GripperState,
    Health,
    HealthState,
    JointState,
    NavigationState,
    OperatorSample,
    SearchSeed,
    Stamped,
    Wrench,
)
from mission.logs.writer import encode_json

#: orjson options of every record (numpy arrays as lists of numbers).
OPTIONS = orjson.OPT_SERIALIZE_NUMPY | orjson.OPT_NON_STR_KEYS
_OPT = OPTIONS
F64 = np.dtype(np.float64)
_ND = ND = np.ndarray


def f64(x: Any) -> np.ndarray:
    """``x`` as a float64 array (no copy when it already is one)."""
    if type(x) is _ND and x.dtype is F64:
        return x
    return np.asarray(x, dtype=float)


def default(obj: Any) -> Any:
    """orjson fallback for what it does not serialize itself."""
    return _default(obj)


def _default(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):  # not C-contiguous, or an odd dtype
        return np.asarray(obj, dtype=float).tolist()
    if isinstance(obj, (np.floating, np.integer, np.bool_)):
        return obj.item()
    if hasattr(obj, "value") and hasattr(obj, "name"):
        return obj.value
    if isinstance(obj, (set, tuple)):
        return list(obj)
    return str(obj)


def _text(x: float) -> str:
    return "nan" if math.isnan(x) else ("inf" if x > 0 else "-inf")


def mark_nonfinite(rec: dict) -> dict:
    """Copy of ``rec`` with non-finite numbers as None, listed in ``nonfinite``."""
    return _mark_nonfinite(rec)


def has_nonfinite(rec: dict) -> bool:
    """Whether :func:`mark_nonfinite` would mark anything in ``rec`` (when not, its copy
    encodes to the same JSON bytes as ``rec``): the same values looked at, the same way.
    A list whose sum is a finite number holds no non-finite float; a list that cannot be
    summed is not one of numbers only (neither is marked); otherwise each entry decides."""
    isfinite = math.isfinite
    for value in rec.values():
        tv = type(value)
        if tv is str or tv is int or value is None:
            continue
        if isinstance(value, float):
            if not isfinite(value):
                return True
        elif isinstance(value, list):
            if not value:
                continue
            try:
                if -_INF < sum(value) < _INF:
                    continue
            except TypeError:
                continue
            if all(isinstance(x, float) for x in value) and not all(map(isfinite, value)):
                return True
        elif isinstance(value, np.ndarray):
            if not all(map(isfinite, value.reshape(-1).tolist())):
                return True
    return False


_INF = math.inf


def _mark_nonfinite(rec: dict) -> dict:
    out: dict[str, Any] = {}
    marks: list[str] = []
    for key, value in rec.items():
        if isinstance(value, list) and value and all(isinstance(x, float) for x in value):
            value = np.asarray(value, dtype=float)
        if isinstance(value, np.ndarray):
            flat = value.reshape(-1).tolist()
            bad = [i for i, x in enumerate(flat) if not math.isfinite(x)]
            if bad:
                marks += [f"{key}.{i}={_text(flat[i])}" for i in bad]
                for i in bad:
                    flat[i] = None
                value = np.asarray(flat, dtype=object).reshape(value.shape).tolist()
            else:
                value = value.tolist()
        elif isinstance(value, float) and not math.isfinite(value):
            marks.append(f"{key}={_text(value)}")
            value = None
        out[key] = value
    if marks:
        out["nonfinite"] = marks
    return out


def dumps(rec: dict) -> bytes:
    """JSON bytes of a record (values: floats, strings, bools, float64 arrays)."""
    data = orjson.dumps(rec, default=_default, option=_OPT)
    if b"null" in data:  # a non-finite number somewhere (or "null" inside a text: harmless)
        data = orjson.dumps(_mark_nonfinite(rec), default=_default, option=_OPT)
    return data


def dumps_value(value: Any) -> str:
    """JSON text of any value (unknown types as text, non-finite numbers as null)."""

    return encode_json({"v": value})[5:-1].decode()


def _restore(d: dict) -> dict:
    """Undo :func:`_mark_nonfinite` on a decoded record (arrays become float64)."""
    marks = d.get("nonfinite")
    if not marks:
        return d
    d = dict(d)
    for mark in marks:
        path, _, text = mark.partition("=")
        key, _, index = path.partition(".")
        value = float(text)
        if index:
            arr = np.array(d[key], dtype=float)  # None -> nan, then the exact value
            arr.reshape(-1)[int(index)] = value
            d[key] = arr
        else:
            d[key] = value
    return d


def _ro(x: Any) -> np.ndarray:
    """Read-only float64 array: code that mutates a reading in place fails loudly
    in a replay instead of silently changing what later calls are served."""
    arr = np.array(x, dtype=float)
    arr.setflags(write=False)
    return arr


def _opt_float(d: dict, key: str) -> float | None:
    v = d.get(key)
    return None if v is None else float(v)


# ------------------------------------------------------------------ encoders
# Arrays are copied into lists of floats (``tolist``): a record is a snapshot that a
# reading changed in place later cannot alter, and orjson writes lists faster.
def _list(x: Any) -> list:
    """``x`` as a list of Python floats (float64 values, flat for a 1-D array)."""
    if type(x) is _ND and x.dtype is F64:
        return x.tolist()
    return np.asarray(x, dtype=float).tolist()


def enc_navigation(nav: NavigationState) -> dict:
    p, a, v = nav.position, nav.attitude, nav.body_velocity
    rec: dict[str, Any] = {
        "t": nav.t,
        "position": p.tolist() if type(p) is _ND and p.dtype is F64 else _list(p),
        "attitude": a.tolist() if type(a) is _ND and a.dtype is F64 else _list(a),
        "depth": nav.depth,
    }
    if v is not None:
        rec["body_velocity"] = v.tolist() if type(v) is _ND and v.dtype is F64 else _list(v)
    if nav.velocity_t is not None:
        rec["velocity_t"] = nav.velocity_t
    if nav.altitude is not None:
        rec["altitude"] = nav.altitude
    return rec


def enc_joints(js: JointState) -> dict:
    p, v, c = js.position, js.velocity, js.current
    rec: dict[str, Any] = {
        "t": js.t,
        "position": p.tolist() if type(p) is _ND and p.dtype is F64 else _list(p),
        "velocity": v.tolist() if type(v) is _ND and v.dtype is F64 else _list(v),
        "current": c.tolist() if type(c) is _ND and c.dtype is F64 else _list(c),
    }
    if js.fault is not None:
        rec["fault"] = js.fault
    return rec


def enc_gripper(gs: GripperState) -> dict:
    rec: dict[str, Any] = {
        "t": gs.t,
        "positions": _list(gs.positions),
        "currents": _list(gs.currents),
        "motion": gs.motion.value,
    }
    if gs.fault is not None:
        rec["fault"] = gs.fault
    return rec


def enc_wrench(w: Wrench | None) -> dict:
    return {"none": True} if w is None else {"t": w.t, "force": _list(w.force), "torque": _list(w.torque)}


def enc_detection(det: Detection | None) -> dict:
    if det is None:
        return {"none": True}
    rec: dict[str, Any] = {
        "t": det.t,
        "pose": f64(det.pose).reshape(-1).tolist(),
        "confidence": det.confidence,
    }  # 4x4 row major
    details = getattr(det, "details", None)
    if details is not None:
        rec["details"] = dumps_value(details)
    return rec


def enc_health(h: Health) -> dict:
    rec: dict[str, Any] = {"state": h.state.value, "t": h.t, "detail": h.detail}
    if h.info:
        rec["info"] = orjson.dumps(h.info, default=_default, option=_OPT).decode()
    return rec


def enc_bool(value: Any) -> dict:
    return {"value": bool(value)}


#: The commands of an operator sample, each written flat as ``<name>``, ``<name>_t``, ``<name>_frame``.
OPERATOR_COMMANDS = ("velocity", "pose", "point", "image_point")


def enc_operator(s: OperatorSample | None) -> dict:
    """An operator input's sample: time, dead-man, each command (values flat, a pose row
    major), the press counts (JSON text, as they come)."""
    if s is None:
        return {"none": True}
    rec: dict[str, Any] = {"t": s.t, "deadman": bool(s.deadman)}
    for name in OPERATOR_COMMANDS:
        st: Stamped | None = getattr(s, name)
        if st is not None:
            rec[name] = f64(st.values).reshape(-1).tolist()
            rec[name + "_t"] = st.t
            if st.frame:
                rec[name + "_frame"] = st.frame
    if s.presses:
        rec["presses"] = orjson.dumps(s.presses, option=orjson.OPT_SORT_KEYS).decode()
    return rec


def enc_seed(seed: SearchSeed) -> dict:
    """A detector's search seed, JSON-able (the arguments of ``detector.seed_search``)."""
    rec: dict[str, Any] = {"t": seed.t, "camera": seed.camera, "radius_px": seed.radius_px}
    if seed.point is not None:
        rec["point"] = f64(seed.point).tolist()
    if seed.image_point is not None:
        rec["image_point"] = f64(seed.image_point).tolist()
    return rec


ENCODERS = {
    "navigation": enc_navigation,
    "joint_state": enc_joints,
    "state": enc_gripper,
    "wrench": enc_wrench,
    "latest": enc_detection,
    "health": enc_health,
    "armed": enc_bool,
}


# ------------------------------------------------------------------ decoders
def dec_navigation(d: dict) -> NavigationState:
    d = _restore(d)
    vel = d.get("body_velocity")
    return NavigationState(
        t=float(d["t"]),
        position=_ro(d["position"]),
        attitude=_ro(d["attitude"]),
        body_velocity=None if vel is None else _ro(vel),
        velocity_t=_opt_float(d, "velocity_t"),
        depth=float(d["depth"]),
        altitude=_opt_float(d, "altitude"),
    )


def dec_joints(d: dict) -> JointState:
    d = _restore(d)
    return JointState(
        t=float(d["t"]),
        position=_ro(d["position"]),
        velocity=_ro(d["velocity"]),
        current=_ro(d["current"]),
        fault=d.get("fault"),
    )


def dec_gripper(d: dict) -> GripperState:
    d = _restore(d)
    return GripperState(
        t=float(d["t"]),
        positions=_ro(d["positions"]),
        currents=_ro(d["currents"]),
        motion=GripperMotion(d["motion"]),
        fault=d.get("fault"),
    )


def dec_wrench(d: dict) -> Wrench | None:
    if d.get("none"):
        return None
    d = _restore(d)
    return Wrench(t=float(d["t"]), force=_ro(d["force"]), torque=_ro(d["torque"]))


def dec_detection(d: dict) -> Detection | None:
    if d.get("none"):
        return None
    d = _restore(d)
    pose = np.array(d["pose"], dtype=float)
    if pose.size == 16:
        pose = pose.reshape(4, 4)
    pose.setflags(write=False)
    if "details" in d:
        return Detection(
            t=float(d["t"]), pose=pose, confidence=float(d["confidence"]), details=orjson.loads(d["details"])
        )
    return Detection(t=float(d["t"]), pose=pose, confidence=float(d["confidence"]))


def dec_health(d: dict) -> Health:
    d = _restore(d)
    info = orjson.loads(d["info"]) if d.get("info") else {}
    return Health(HealthState(d["state"]), float(d["t"]), d.get("detail", ""), info)


def dec_bool(d: dict) -> bool:
    return bool(d["value"])


def dec_operator(d: dict) -> OperatorSample | None:
    if d.get("none"):
        return None
    d = _restore(d)
    commands: dict[str, Stamped] = {}
    for name in OPERATOR_COMMANDS:
        if name in d:
            values = _ro(d[name])
            if name == "pose":
                values = values.reshape(4, 4)
            commands[name] = Stamped(float(d[name + "_t"]), values, d.get(name + "_frame", ""))
    presses = orjson.loads(d["presses"]) if "presses" in d else {}
    return OperatorSample(t=float(d["t"]), deadman=bool(d["deadman"]), presses=presses, **commands)


DECODERS = {
    "navigation": dec_navigation,
    "joint_state": dec_joints,
    "state": dec_gripper,
    "wrench": dec_wrench,
    "latest": dec_detection,
    "health": dec_health,
    "armed": dec_bool,
}


# ---------------------------------------------------------------- exceptions
def error_fields(exc: BaseException) -> dict:
    """``{"error_type", "error"[, "error_module"]}`` of an exception raised by a device call
    (the module when it is not a builtin, e.g. ``hal.interfaces`` for ``EngageRefused``)."""
    out = {"error_type": type(exc).__name__, "error": str(exc)}
    module = type(exc).__module__
    if module != "builtins":
        out["error_module"] = module
    return out


def _exception_class(type_name: str, module: str | None) -> type | None:
    """The logged exception's class: a builtin, or one of the HAL's (``hal`` and its
    modules only: a log names it, and a log is data, so nothing else is imported)."""
    if module in (None, "builtins"):
        cls = getattr(builtins, type_name, None)
    elif module == "hal" or module.startswith("hal."):
        try:
            cls = getattr(importlib.import_module(module), type_name, None)
        except ImportError:
            cls = None
    else:
        cls = None
    return cls if isinstance(cls, type) and issubclass(cls, Exception) and cls is not Exception else None


class ReplayedError(Exception):
    """Marker base of exceptions re-raised from the log (``replayed = True``)."""

    replayed = True


def rebuild_error(type_name: str, message: str, module: str | None = None) -> Exception:
    """An exception whose ``type(e).__name__`` and ``str(e)`` are the logged ones,
    and which is an instance of the logged class when it is a builtin or a HAL
    exception (so ``except OSError`` or ``except EngageRefused`` catches the
    replayed exception as it caught the original)."""
    base = _exception_class(type_name, module)
    bases: tuple[type, ...] = (ReplayedError,) if base is None else (base, ReplayedError)
    for candidate in (bases, (ReplayedError,)):
        try:
            cls = type(type_name, candidate, {"__str__": lambda self, m=message: m, "__module__": "replayed"})
            return cls(message)
        except TypeError:  # a builtin whose layout or constructor does not allow this
            continue
    return ReplayedError(message)
