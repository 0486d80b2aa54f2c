"""What a behaviour-tree leaf may touch: :class:`MissionContext`.

The supervisor (``mission/runtime``) builds one concrete context per run and
passes it to :func:`mission.compiler.compile_mission`. Leaves use it to read
the clock and the devices, switch the KCL action and its targets, read and
write the blackboard, and emit log events. They never run the KCL loop (the
supervisor does, at its own rates) and never block a tick.

Halt contract: ``stop_motion()`` must, right away, call ``controller.stop(t)``
and command zero velocities to the vehicle and the arm. A leaf interrupted
while it commands motion calls it before returning from ``terminate``.

This module also holds small concrete parts any context can reuse:
:class:`MissionBlackboard` (typed keys, stored in the py_trees blackboard so
py_trees tools display them), :class:`EventList` (an in-memory event sink) and
:class:`OperatorBoard` (who has control).
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np
import py_trees

from hal.interfaces import DeviceSet

#: py_trees blackboard namespace of mission keys.
NAMESPACE = "/mission"
_Blackboard = py_trees.blackboard.Blackboard


@runtime_checkable
class EventSink(Protocol):
    """Receives events for the run log."""

    def emit(self, kind: str, message: str, **fields: Any) -> object:
        """Record an event of ``kind`` (e.g. ``action_start``) with JSON-able fields
        (what it returns, e.g. the event recorded, is the sink's own business)."""
        ...


@runtime_checkable
class MissionContext(Protocol):
    """Everything leaves may use (see the module docstring).

    devices: the backend's :class:`hal.interfaces.DeviceSet`.
    controller: the :class:`kcl.controller.UvmsController` driven by the supervisor
    (leaves call ``set_action``, ``set_targets``, ``telemetry`` only).
    blackboard: typed mission keys (:class:`MissionBlackboard`).
    events: the event sink of the run log.
    operator: where a running ``teleop`` leaf reports who has control (:class:`OperatorBoard`).
    """

    @property
    def devices(self) -> DeviceSet: ...

    @property
    def controller(self) -> Any: ...

    @property
    def blackboard(self) -> MissionBlackboard: ...

    @property
    def events(self) -> EventSink: ...

    @property
    def operator(self) -> OperatorBoard: ...

    def now(self) -> float:
        """Backend clock time, s."""
        ...

    def stop_motion(self) -> None:
        """Halt contract: controller.stop and zero vehicle/arm velocity commands now."""
        ...


@dataclass
class OperatorBoard:
    """Who has control, for the log: a running ``teleop`` leaf puts its status here at
    each tick (a JSON-able dict: mode, input, command, what limits it) and clears it when
    it ends; the supervisor writes it to the run log (``/operator/teleop``)."""

    status: dict[str, Any] | None = None


@dataclass
class EventList:
    """An :class:`EventSink` keeping events in memory as dicts (tests, dry runs)."""

    events: list[dict] = field(default_factory=list)

    def emit(self, kind: str, message: str, **fields: Any) -> None:
        self.events.append({"kind": kind, "message": message, **fields})

    def kinds(self) -> list[str]:
        return [e["kind"] for e in self.events]


class BlackboardTypeError(TypeError):
    """A value of the wrong type was written to a typed mission key."""


def _check_type(btype: str, value: Any) -> Any:
    """Validated runtime value for blackboard type ``btype`` (raises BlackboardTypeError)."""
    if btype == "bool" and isinstance(value, (bool, np.bool_)):
        return bool(value)
    if btype == "int" and isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        return int(value)
    if btype == "float" and isinstance(value, (int, float, np.floating, np.integer)) and not isinstance(value, bool):
        return float(value)
    if btype == "str" and isinstance(value, str):
        return value
    if btype in ("pose", "point"):
        shape = (4, 4) if btype == "pose" else (3,)
        arr = np.asarray(value, dtype=float)
        if arr.shape == shape and np.all(np.isfinite(arr)):
            arr = arr.copy()
            arr.setflags(write=False)
            return arr
    raise BlackboardTypeError(f"blackboard: value {value!r} is not a valid {btype}")


class MissionBlackboard:
    """Typed mission keys stored under ``/mission/run<N>/<key>`` in the py_trees blackboard.

    types: key -> type name (``bool int float str pose point``); initial: key ->
    value. Each instance has its own namespace and starts from the initial
    values (other keys unset). Poses are (4, 4) world NED arrays (m), points (3,) (m); stored
    arrays are read-only copies, so a reader can compare by identity to see a
    new value.
    """

    _instances = itertools.count(1)

    def __init__(self, types: Mapping[str, str], initial: Mapping[str, Any] | None = None):
        self.types = dict(types)
        #: py_trees namespace of this blackboard: one per instance, so runs in
        #: threads of one process never share values.
        self.namespace = f"{NAMESPACE}/run{next(self._instances)}"
        self._client = py_trees.blackboard.Client(name=f"mission {self.namespace}")
        for key in self.types:
            self._client.register_key(key=self._full(key), access=py_trees.common.Access.WRITE)
            py_trees.blackboard.Blackboard.unset(self._full(key))
        #: key -> its py_trees storage name, for the direct path of get/set/is_set (see _direct_name)
        self._storage_names = {
            key: self._client.remappings[self._full(key)] for key in self.types if "." not in self._full(key)
        }
        for key, value in (initial or {}).items():
            self.set(key, value)

    @classmethod
    def for_mission(cls, mission: Any) -> MissionBlackboard:
        """Blackboard with the keys, types and initial values declared by a mission."""
        return cls({k: v.type for k, v in mission.blackboard.items()}, mission.initial_blackboard())

    def _full(self, key: str) -> str:
        return f"{self.namespace}/{key}"

    def release(self) -> None:
        """Remove this blackboard's values and client from py_trees (end of a run)."""
        for key in self.types:
            py_trees.blackboard.Blackboard.unset(self._full(key))
        self._client.unregister(clear=True)

    def _type(self, key: str) -> str:
        try:
            return self.types[key]
        except KeyError:
            raise KeyError(f"blackboard key `{key}` is not declared by the mission") from None

    def _direct_name(self, key: str) -> str | None:
        """The py_trees storage name of declared ``key`` when the client's checks would only
        look it up there (write access, no nested name, no activity stream to feed), else
        None: then the py_trees client does it. The client's ``get`` checks access each
        time; the leaves, the log and the 3D view read keys every tree tick."""
        if _Blackboard.activity_stream is not None:
            return None
        return self._storage_names.get(key)

    def set(self, key: str, value: Any) -> None:
        """Write ``value`` (type-checked) to ``key``."""
        checked = _check_type(self._type(key), value)
        name = self._direct_name(key)
        if name is not None:
            _Blackboard.storage[name] = checked
        else:
            self._client.set(self._full(key), checked, overwrite=True)

    def get(self, key: str, default: Any = None) -> Any:
        """Value of ``key``, or ``default`` while it is unset."""
        name = self._direct_name(key)
        if name is not None:
            return _Blackboard.storage.get(name, default)
        self._type(key)
        try:
            return self._client.get(self._full(key))
        except KeyError:
            return default

    def is_set(self, key: str) -> bool:
        name = self._direct_name(key)
        if name is not None:
            return name in _Blackboard.storage
        self._type(key)
        return py_trees.blackboard.Blackboard.exists(self._full(key))

    def snapshot(self) -> dict[str, Any]:
        """JSON-able copy of every set key (arrays as lists), for logs."""
        out = {}
        for key in self.types:
            if self.is_set(key):
                v = self.get(key)
                out[key] = v.tolist() if isinstance(v, np.ndarray) else v
        return out
