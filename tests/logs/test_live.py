"""`--live`: real WebSocket clients on 127.0.0.1, one per subprotocol name, see
the channels with their schemas, get the file's bytes, get latched values when
they join late, and send operator commands the supervisor obeys and logs;
a client with the wrong token is refused."""

from __future__ import annotations

import json
import struct
import threading
import time
from pathlib import Path

import pytest
from websockets.exceptions import InvalidStatus
from websockets.sync.client import connect

from mission.logs.channels import CHANNELS
from mission.logs.live import LiveServer
from mission.logs.reader import read_log
from mission.logs.wellknown import WELL_KNOWN
from mission.logs.writer import RunLogWriter
from mission.runtime.operator import CommandQueue
from mission.runtime.options import RunHooks, RunOptions, RunTarget

pytestmark = pytest.mark.realtime  # a live WebSocket client with receive timeouts

ROOT = Path(__file__).resolve().parents[2]


class Client:
    """A minimal Foxglove WebSocket client (the protocol's JSON ops and binary frames)."""

    def __init__(self, url: str, subprotocol: str) -> None:
        self.ws = connect(url, subprotocols=[subprotocol], open_timeout=10, max_queue=None).__enter__()
        self.replies: list[tuple[int, dict]] = []
        self.times: list[int] = []
        self.channels: dict[str, dict] = {}
        self.services: dict[str, dict] = {}
        self.info: dict = {}
        self.statuses: list[dict] = []
        self.sub_topics: dict[int, str] = {}
        deadline = time.monotonic() + 10
        while (not self.channels or not self.services) and time.monotonic() < deadline:
            msg = json.loads(self.ws.recv(timeout=5))
            if msg["op"] == "serverInfo":
                self.info = msg
            elif msg["op"] == "advertise":
                self.channels.update({c["topic"]: c for c in msg["channels"]})
            elif msg["op"] == "advertiseServices":
                self.services.update({s["name"]: s for s in msg["services"]})

    def subscribe(self, *topics: str) -> None:
        subs = []
        for topic in topics:
            sub_id = len(self.sub_topics) + 1
            self.sub_topics[sub_id] = topic
            subs.append({"id": sub_id, "channelId": self.channels[topic]["id"]})
        self.ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))

    def messages(self, until, timeout: float = 10.0) -> list[tuple[str, int, bytes]]:
        got: list[tuple[str, int, bytes]] = []
        deadline = time.monotonic() + timeout
        while not until(got):
            assert time.monotonic() < deadline, f"timed out; got {[g[0] for g in got]}"
            frame = self.ws.recv(timeout=max(0.1, deadline - time.monotonic()))
            if isinstance(frame, str):
                self.statuses.append(json.loads(frame))
                continue
            if frame[0] == 2:  # the server's time
                self.times.append(struct.unpack_from("<Q", frame, 1)[0])
                continue
            if frame[0] == 3:  # service call response
                _, call_id, n = struct.unpack_from("<III", frame, 1)
                self.replies.append((call_id, json.loads(frame[13 + n :])))
                continue
            op, sub, ts = struct.unpack("<BIQ", frame[:13])
            assert op == 1
            got.append((self.sub_topics[sub], ts, frame[13:]))
        return got

    def publish_command(self, command: str) -> None:
        self.ws.send(
            json.dumps(
                {
                    "op": "advertise",
                    "channels": [
                        {
                            "id": 7,
                            "topic": "/operator/command",
                            "encoding": "json",
                            "schemaName": "maris.OperatorCommand",
                        }
                    ],
                }
            )
        )
        self.ws.send(struct.pack("<BI", 1, 7) + json.dumps({"command": command}).encode())

    def call_service(self, name: str, call_id: int = 1) -> None:
        sid = self.services[name]["id"]
        self.ws.send(struct.pack("<BIII", 2, sid, call_id, 4) + b"json" + b"{}")

    def close(self) -> None:
        self.ws.__exit__(None, None, None)


@pytest.mark.parametrize("subprotocol", ["foxglove.websocket.v1", "foxglove.sdk.v1"])
def test_client_of_each_subprotocol_gets_channels_messages_and_latched_values(tmp_path, subprotocol):
    server = LiveServer(port=0)
    assert server.url.startswith("ws://127.0.0.1:")
    writer = RunLogWriter(tmp_path / "live.mcap", live=server)
    try:
        writer.write("/run/config", 0.0, {"mission_name": "m"})
        writer.write("/supervisor/state", 0.0, {"state": "running"})
        writer.write("/supervisor/state", 0.5, {"state": "paused"})
        client = Client(server.url, subprotocol)  # joins after those were written
        try:
            assert client.ws.subprotocol == subprotocol
            assert set(client.channels) == set(CHANNELS) | set(WELL_KNOWN)
            assert "clientPublish" in client.info["capabilities"] and "services" in client.info["capabilities"]
            cmd = client.channels["/vehicle/command"]
            assert cmd["encoding"] == "json" and json.loads(cmd["schema"])["title"] == "VehicleCommand"
            assert client.channels["/tf"]["encoding"] == "protobuf"
            client.subscribe("/vehicle/command", "/run/config", "/supervisor/state")
            latched = client.messages(lambda g: len(g) >= 2)
            assert {t: json.loads(d) for t, _, d in latched} == {
                "/run/config": {"mission_name": "m", "t": 0.0},
                "/supervisor/state": {"state": "paused", "t": 0.5},
            }
            time.sleep(0.2)  # the subscription is in place once its latched values are out
            writer.write("/events", 0.6, {"kind": "x", "level": "info", "message": "not subscribed", "fields": {}})
            for k in range(3):
                writer.write("/vehicle/command", 1.0 + k, {"body_velocity": [0.1 * k, 0, 0, 0, 0, 0]})
            got = client.messages(lambda g: len(g) >= 3)
        finally:
            client.close()
    finally:
        writer.close()
    assert [(t, ts) for t, ts, _ in got] == [
        ("/vehicle/command", 1_000_000_000),
        ("/vehicle/command", 2_000_000_000),
        ("/vehicle/command", 3_000_000_000),
    ]
    assert json.loads(got[2][2]) == {"body_velocity": [0.2, 0, 0, 0, 0, 0], "t": 3.0}
    assert "time" in client.info["capabilities"] and client.times and client.times[-1] <= 3_000_000_000
    assert read_log(tmp_path / "live.mcap").messages("/vehicle/command") == [json.loads(d) for _, _, d in got]


def test_token_required_off_loopback_and_wrong_token_refused():
    with pytest.raises(ValueError, match="token"):
        LiveServer(port=0, host="0.0.0.0")
    # on loopback with a token (the refusal path is the same on any address)
    server = LiveServer(port=0, token="s3cret")
    try:
        base = f"ws://127.0.0.1:{server.port}"
        for url in (base, base + "/?token=nope"):
            with pytest.raises(InvalidStatus) as err:
                connect(url, subprotocols=["foxglove.websocket.v1"], open_timeout=10)
            assert err.value.response.status_code == 401
        ok = Client(server.url, "foxglove.websocket.v1")
        assert "/tf" in ok.channels
        ok.close()
        with connect(
            base,
            subprotocols=["foxglove.sdk.v1"],
            open_timeout=10,
            additional_headers={"Authorization": "Bearer s3cret"},
        ) as header:
            assert header.subprotocol == "foxglove.sdk.v1"
    finally:
        server.close()
    notices = [text for _, text in server.notices]
    assert any("wrong access token" in n for n in notices) and any("no access token" in n for n in notices)


@pytest.mark.slow
def test_operator_commands_from_a_client_are_obeyed_and_logged(tmp_path):
    """A real run: the client joins late (latched config), publishes pause, then
    calls the abort service; the run pauses, aborts, and its log says who asked."""
    from mission.runtime.api import run_mission

    queue = CommandQueue()
    server = LiveServer(port=0, commands=queue)
    joined = threading.Event()
    started = threading.Event()

    def hold_until_joined(_now: float) -> None:  # the run waits (once) for the client
        started.set()
        joined.wait(30)

    result: dict = {}
    run = threading.Thread(
        target=lambda: result.update(
            r=run_mission(
                RunTarget(ROOT / "missions" / "maris_pipe_recovery.yaml", seed=1),
                RunOptions(log_path=tmp_path / "run.mcap"),
                RunHooks(commands=queue, pollers=[hold_until_joined], live=server),
            )
        )
    )
    run.start()
    try:
        assert started.wait(60)
        client = Client(server.url, "foxglove.websocket.v1")
        client.subscribe("/run/config", "/supervisor/state", "/scene/robot")
        latched = client.messages(
            lambda g: {t for t, _, _ in g} >= {"/run/config", "/supervisor/state", "/scene/robot"}
        )
        config = next(json.loads(d) for t, _, d in latched if t == "/run/config")
        assert config["mission_name"] == "maris_pipe_recovery"
        client.publish_command("pause")
        time.sleep(0.3)
        client.call_service("/operator/abort", call_id=42)
        joined.set()
        states = client.messages(
            lambda g: any(t == "/supervisor/state" and json.loads(d)["state"] == "aborting" for t, _, d in g),
            timeout=60,
        )
        client.messages(lambda g: client.replies)
        client.close()
    finally:
        joined.set()
        run.join(120)
        server.close()
    assert [json.loads(d)["state"] for t, _, d in states if t == "/supervisor/state"][-2:] == ["paused", "aborting"]
    assert client.replies == [(42, {"accepted": True, "command": "abort"})]
    assert result["r"].outcome == "aborted"
    log = read_log(tmp_path / "run.mcap")
    operator = [e for e in log.messages("/events") if e["kind"] == "operator"]
    assert [e["fields"]["command"] for e in operator] == ["pause", "abort"]
    assert all(e["fields"]["source"].startswith("Foxglove client 127.0.0.1:") for e in operator)
    assert any(e["kind"] == "live" and "connected" in e["message"] for e in log.messages("/events"))


def test_maris_watch_shows_the_latched_tree(tmp_path):
    import contextlib
    import io

    from mission.cli import main

    server = LiveServer(port=0)
    writer = RunLogWriter(tmp_path / "w.mcap", live=server)
    try:
        nodes = [
            {"name": "Pipe recovery", "kind": "sequence_with_memory", "status": "RUNNING", "depth": 0},
            {"name": "Survey", "kind": "behaviour", "status": "RUNNING", "depth": 1, "message": "heading to WP2"},
        ]
        writer.write("/tree", 4.0, {"nodes": nodes, "tip": "Survey", "root_status": "RUNNING"})
        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            code = main(["watch", server.url, "--once"])
    finally:
        writer.close()
    assert code == 0
    assert "{-} Pipe recovery [*]\n    --> Survey [*] -- heading to WP2" in out.getvalue()
    assert "running leaf: Survey" in out.getvalue()
