"""Teleop runs on the simulator, driven by scripted operator inputs:

* a recorded gamepad stream (an evemu file of an Xbox 360 pad's kernel events,
  :mod:`hal.testing.gamepad_session`) played by the simulator's pad through the
  real driver's decoding;
* a real Foxglove-protocol WebSocket client (:class:`FoxgloveOperator`) publishing
  ``geometry_msgs`` messages as JSON to the run's live server, in lock step with
  the run: a poller, called by the supervisor at each tree step, sends what is
  due at that simulated time and waits until the server has handed it to the
  run's ``foxglove`` input, so what the run sees does not depend on thread timing.
"""

from __future__ import annotations

import json
import math
import struct
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest
from websockets.sync.client import connect

import mission.replay.record  # noqa: F401 - registers the input record (replay tests)
from hal.testing.gamepad_session import Hold, write_session
from mission.logs.live import LiveServer
from mission.logs.reader import read_log
from mission.runtime.api import run_mission
from mission.runtime.options import RunHooks, RunOptions, RunTarget

MISSION = """name: {name}
safety:
  max_depth_m: 4.0
  min_altitude_m: 0.5
  max_duration_s: 900
  geofence: {{north_m: [0, {north}], east_m: [0, 12], down_m: [0, 4]}}
tree:
  sequence:
    children:
{fold}      - teleop:
{teleop}
abort:
  action: {{run: hold, timeout_s: 10}}
"""


FOLD = "      - action: {name: Fold the arm, run: transport, until: converged, timeout_s: 30}\n"


def teleop_mission(path: Path, *, north: float = 25.0, fold: bool = True, **fields: Any) -> Path:
    """A mission: fold the arm (unless not ``fold``), then a teleop node with ``fields``
    (YAML flow values); the geofence ends at ``north`` m."""
    lines = "\n".join(f"          {k}: {json.dumps(v) if not isinstance(v, str) else v}" for k, v in fields.items())
    path.write_text(MISSION.format(name=path.stem, north=north, teleop=lines, fold=FOLD if fold else ""))
    return path


@dataclass
class Run:
    """A finished run: its result, its log (read back) and its events."""

    result: Any
    log: Any
    log_path: Path

    def events(self, *kinds: str) -> list[dict]:
        return [e for e in self.log.messages("/events") if not kinds or e["kind"] in kinds]

    def teleop_start(self) -> float:
        return next(e["t"] for e in self.events("control") if e["fields"]["who"] == "operator")


def run_with_pad(tmp_path: Path, mission: Path, holds: list[Hold], end_s: float, **overrides: Any) -> Run:
    """Run ``mission`` on pool_clear with a recorded pad session (starting at the first read)."""
    rec = write_session(tmp_path / "pad.evemu", holds, end_s=end_s)
    log = tmp_path / "run.mcap"
    result = run_mission(
        RunTarget(
            mission, scenario="pool_clear", seed=1, overrides={"operator.gamepad_recording": str(rec), **overrides}
        ),
        RunOptions(log_path=log),
    )
    return Run(result, read_log(log), log)


# --------------------------------------------------------------------------- Foxglove


@dataclass
class Step:
    """At simulated time ``t`` (s from the start of the teleop node), ``action(client, now)``."""

    t: float
    action: Callable[[FoxgloveOperator, float], None]


class FoxgloveOperator:
    """A Foxglove WebSocket client that publishes the operator's messages (JSON), as
    Foxglove Studio does: it advertises a client channel per topic with the ROS schema
    name, then sends binary message frames on it; services are called by id."""

    def __init__(self, url: str) -> None:
        # max_queue=None: the client's reader keeps reading what the server sends (time,
        # status) though the test never asks for it, so the close handshake goes through
        self.ws = connect(url, subprotocols=["foxglove.websocket.v1"], open_timeout=10, max_queue=None).__enter__()
        self.info: dict = {}
        self.services: dict[str, dict] = {}
        self._channels: dict[str, int] = {}
        deadline = time.monotonic() + 10
        while not self.services and time.monotonic() < deadline:
            msg = json.loads(self.ws.recv(timeout=5))
            if msg["op"] == "serverInfo":
                self.info = msg
            elif msg["op"] == "advertiseServices":
                self.services = {s["name"]: s for s in msg["services"]}
        self.closed = False

    def publish(self, topic: str, schema: str, msg: dict) -> None:
        cid = self._channels.get(topic)
        if cid is None:
            cid = self._channels[topic] = len(self._channels) + 100
            channel = {"id": cid, "topic": topic, "encoding": "json", "schemaName": schema}
            self.ws.send(json.dumps({"op": "advertise", "channels": [channel]}))
        self.ws.send(struct.pack("<BI", 1, cid) + json.dumps(msg).encode())

    def twist(self, v: list[float], stamp: float | None = None) -> None:
        twist = {"linear": dict(zip("xyz", v[:3])), "angular": dict(zip("xyz", v[3:]))}
        if stamp is None:
            self.publish("/operator/cmd_vel", "geometry_msgs/Twist", twist)
        else:
            msg = {"header": _header(stamp, ""), "twist": twist}
            self.publish("/operator/cmd_vel", "geometry_msgs/TwistStamped", msg)

    def pose(self, frame: str, xyz: tuple[float, float, float], yaw: float, stamp: float) -> None:
        q = {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}
        msg = {"header": _header(stamp, frame), "pose": {"position": dict(zip("xyz", xyz)), "orientation": q}}
        self.publish("/operator/goal_pose", "geometry_msgs/PoseStamped", msg)

    def point(self, frame: str, xyz: tuple[float, float, float], stamp: float) -> None:
        msg = {"header": _header(stamp, frame), "point": dict(zip("xyz", xyz))}
        self.publish("/operator/goal_point", "geometry_msgs/PointStamped", msg)

    def command(self, msg: dict) -> None:
        self.publish("/operator/command", "maris.OperatorCommand", msg)

    def call_service(self, name: str, call_id: int = 1) -> None:
        sid = self.services[name]["id"]
        self.ws.send(struct.pack("<BIII", 2, sid, call_id, 4) + b"json" + b"{}")

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            self.ws.__exit__(None, None, None)


def _header(stamp: float, frame: str) -> dict:
    sec = math.floor(stamp)
    return {"stamp": {"sec": sec, "nsec": int(round((stamp - sec) * 1e9))}, "frame_id": frame}


@dataclass
class LockStep:
    """The poller of a run driven by a :class:`FoxgloveOperator` (see the module docstring)."""

    server: LiveServer
    steps: list[Step]
    client: FoxgloveOperator | None = None
    t0: float | None = None
    done: list[float] = field(default_factory=list)

    def __call__(self, now: float) -> None:
        device = self.server.operator_input
        if self.t0 is None:
            return
        while self.steps and self.t0 + self.steps[0].t <= now + 1e-9:
            step = self.steps.pop(0)
            before = device.health().info["received"]
            assert self.client is not None
            step.action(self.client, now)
            self.done.append(now)
            deadline = time.monotonic() + 10
            if not self.client.closed:  # wait until the server has handed it to the input
                while device.health().info["received"] == before:
                    assert time.monotonic() < deadline, "the live server did not deliver the message"
                    time.sleep(0.001)


def run_with_foxglove(
    tmp_path: Path, mission: Path, steps: list[Step], scenario: str = "pool_clear", **overrides: Any
) -> Run:
    """Run ``mission`` with a Foxglove client following ``steps`` (times from the teleop's start)."""
    server = LiveServer(port=0)
    lock = LockStep(server, list(steps))

    def on_event(ev: Any) -> None:
        if ev.kind == "control" and ev.fields.get("who") == "operator" and lock.t0 is None:
            lock.t0 = ev.t

    log = tmp_path / "run.mcap"
    try:
        lock.client = FoxgloveOperator(server.url)
        result = run_mission(
            RunTarget(mission, scenario=scenario, seed=1, overrides=overrides or None),
            RunOptions(log_path=log),
            RunHooks(live=server, pollers=[lock], on_event=on_event),
        )
    finally:
        if lock.client is not None:
            lock.client.close()
        server.close()
    return Run(result, read_log(log), log)


@pytest.fixture
def kit(tmp_path):
    """The helpers of this file (test modules cannot import conftest): ``Step``, ``Hold``,
    ``mission(name, **teleop_fields)``, ``pad(mission, holds, end_s, **overrides)``,
    ``foxglove(mission, steps, **overrides)``."""
    return SimpleNamespace(
        Step=Step,
        Hold=Hold,
        mission=lambda name, **fields: teleop_mission(tmp_path / f"{name}.yaml", **fields),
        pad=lambda mission, holds, end_s, **kw: run_with_pad(tmp_path, mission, holds, end_s, **kw),
        foxglove=lambda mission, steps, **kw: run_with_foxglove(tmp_path, mission, steps, **kw),
    )
