"""The live server as the operator's input: a real Foxglove-protocol WebSocket client
on 127.0.0.1 publishes what Foxglove Studio's Teleop and 3D panels and Publish panels
send (JSON ``geometry_msgs``, buttons, modes) and calls the handback service; the run's
``foxglove`` input gets each, dated, in its frame; the server announces the ROS profile
Studio 1.48 needs to publish 3D clicks; a client that goes away is said to the input."""

from __future__ import annotations

import json
import math
import struct
import time

import pytest
from websockets.sync.client import connect

from hal.drivers.pushed_input import PushedInput
from mission.logs.live import LiveServer
from mission.runtime.operator import CommandQueue

pytestmark = pytest.mark.realtime  # a live WebSocket client with receive timeouts


class Client:
    def __init__(self, url: str) -> None:
        self.ws = connect(url, subprotocols=["foxglove.websocket.v1"], open_timeout=10).__enter__()
        self.info: dict = {}
        self.services: dict = {}
        self.statuses: list[dict] = []
        while not self.services:
            msg = json.loads(self.ws.recv(timeout=5))
            if msg["op"] == "serverInfo":
                self.info = msg
            elif msg["op"] == "advertiseServices":
                self.services = {s["name"]: s for s in msg["services"]}
        self._ids: dict[str, int] = {}

    def publish(self, topic: str, schema: str, msg: dict) -> None:
        if topic not in self._ids:
            self._ids[topic] = cid = len(self._ids) + 1
            channel = {"id": cid, "topic": topic, "encoding": "json", "schemaName": schema}
            self.ws.send(json.dumps({"op": "advertise", "channels": [channel]}))
        self.ws.send(struct.pack("<BI", 1, self._ids[topic]) + json.dumps(msg).encode())

    def call(self, name: str, call_id: int = 5) -> dict:
        sid = self.services[name]["id"]
        self.ws.send(struct.pack("<BIII", 2, sid, call_id, 4) + b"json" + b"{}")
        while True:
            frame = self.ws.recv(timeout=5)
            if isinstance(frame, bytes) and frame[0] == 3:
                _, got, n = struct.unpack_from("<III", frame, 1)
                assert got == call_id
                return json.loads(frame[13 + n :])
            if isinstance(frame, str) and json.loads(frame)["op"] == "status":
                self.statuses.append(json.loads(frame))

    def status(self) -> dict:
        while True:
            frame = self.ws.recv(timeout=5)
            if isinstance(frame, str) and json.loads(frame)["op"] == "status":
                return json.loads(frame)

    def close(self) -> None:
        self.ws.__exit__(None, None, None)


def _until(cond, timeout: float = 5.0) -> None:
    end = time.monotonic() + timeout
    while not cond():
        assert time.monotonic() < end
        time.sleep(0.005)


@pytest.fixture
def served():
    clock = [50.0]
    device = PushedInput("foxglove", lambda: clock[0], lambda: clock[0])
    queue = CommandQueue()
    server = LiveServer(port=0, commands=queue)
    server.attach_input(device)
    client = Client(server.url)
    yield server, client, device, clock, queue
    client.close()
    server.close()


def test_the_server_says_ros1_so_studio_publishes_3d_clicks_and_takes_them_as_json(served):
    server, client, device, clock, queue = served
    assert client.info["metadata"]["ROS_DISTRO"] == "noetic"
    assert client.info["supportedEncodings"] == ["json"] and "clientPublish" in client.info["capabilities"]
    assert "/operator/handback" in client.services
    plain = LiveServer(port=0, ros_profile=False)
    try:
        other = Client(plain.url)
        assert "ROS_DISTRO" not in other.info["metadata"]
        other.close()
    finally:
        plain.close()


def test_twist_pose_point_and_image_clicks_reach_the_input_dated_and_in_their_frames(served):
    server, client, device, clock, queue = served
    client.publish(
        "/operator/cmd_vel",
        "geometry_msgs/Twist",
        {"linear": {"x": 0.1, "y": 0, "z": 0}, "angular": {"x": 0, "y": 0, "z": -0.2}},
    )
    _until(lambda: device.latest() is not None and device.latest().velocity is not None)
    s = device.latest()
    assert s.velocity.values.tolist() == [0.1, 0, 0, 0, 0, -0.2] and s.velocity.t == 50.0
    yaw = 0.5
    pose = {
        "header": {"stamp": {"sec": 48, "nsec": 500_000_000}, "frame_id": "map"},  # 1.5 s before now (50 s)
        "pose": {
            "position": {"x": 2.0, "y": 3.0, "z": 0.0},
            "orientation": {"x": 0, "y": 0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)},
        },
    }
    client.publish("/operator/goal_pose", "geometry_msgs/PoseStamped", pose)
    _until(lambda: device.latest().pose is not None)
    p = device.latest().pose
    assert p.frame == "map" and p.t == pytest.approx(48.5)
    assert p.values[:3, 3].tolist() == [2.0, 3.0, 0.0]
    assert math.atan2(p.values[1, 0], p.values[0, 0]) == pytest.approx(yaw)
    client.publish(
        "/operator/goal_point",
        "geometry_msgs/PointStamped",
        {
            "header": {"stamp": {"sec": 50, "nsec": 0}, "frame_id": "vehicle_level"},
            "point": {"x": 0.5, "y": 1.0, "z": 0.0},
        },
    )
    _until(lambda: device.latest().point is not None)
    assert device.latest().point.frame == "vehicle_level" and device.latest().point.values.tolist() == [0.5, 1.0, 0.0]
    client.publish("/operator/image_point", "maris.ImagePoint", {"u": 320, "v": 240, "camera": "left"})
    _until(lambda: device.latest().image_point is not None)
    assert device.latest().image_point.values.tolist() == [320, 240] and device.latest().image_point.frame == "left"
    stamped = {
        "header": {"stamp": {"sec": 47, "nsec": 0}, "frame_id": ""},
        "twist": {"linear": {"x": 0.2, "y": 0, "z": 0}, "angular": {"x": 0, "y": 0, "z": 0}},
    }
    client.publish("/operator/cmd_vel", "geometry_msgs/TwistStamped", stamped)
    _until(lambda: device.latest().velocity.values[0] == 0.2)
    assert device.latest().velocity.t == pytest.approx(47.0)  # dated by its stamp: 3 s old


def test_buttons_modes_and_the_handback_service_are_presses_and_pause_still_a_command(served):
    server, client, device, clock, queue = served
    client.publish("/operator/command", "maris.OperatorCommand", {"button": "handback"})
    client.publish("/operator/command", "maris.OperatorCommand", {"mode": "point_at"})
    client.publish("/operator/command", "maris.OperatorCommand", {"command": "pause"})
    _until(lambda: device.latest() is not None and device.latest().count("mode:point_at") == 1)
    assert client.call("/operator/handback") == {"accepted": True, "command": "handback"}
    s = device.latest()
    assert s.presses == {"handback": 1, "mode:point_at": 1, "service:handback": 1}
    _until(lambda: queue._q)
    assert [c.command for c in queue.drain()] == ["pause"]
    client.publish("/operator/command", "maris.OperatorCommand", {"button": "launch"})
    assert "unknown button 'launch'" in client.status()["message"]
    client.publish("/operator/goal_pose", "geometry_msgs/PoseStamped", {"pose": {}})
    assert "cannot read the message" in client.status()["message"]


def test_a_client_leaving_is_said_to_the_input(served):
    server, client, device, clock, queue = served
    _until(lambda: device.health().info["senders"] == 1)
    client.close()
    _until(lambda: device.health().info["senders"] == 0)
    assert "disconnected" in device.health().detail


def test_without_an_input_teleop_messages_are_refused_with_a_status():
    server = LiveServer(port=0)
    try:
        client = Client(server.url)
        client.publish(
            "/operator/cmd_vel",
            "geometry_msgs/Twist",
            {"linear": {"x": 1, "y": 0, "z": 0}, "angular": {"x": 0, "y": 0, "z": 0}},
        )
        assert "no foxglove operator input" in client.status()["message"]
        client.close()
    finally:
        server.close()
