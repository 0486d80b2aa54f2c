"""`--live`: a real Foxglove WebSocket client on 127.0.0.1 sees the log channels
with their schemas and receives the same JSON bytes as the file."""

from __future__ import annotations

import json
import struct
import time

import pytest

pytest.importorskip("foxglove")
from websockets.sync.client import connect  # noqa: E402

from mission.logs.channels import CHANNELS  # noqa: E402
from mission.logs.live import LiveServer  # noqa: E402
from mission.logs.reader import read_log  # noqa: E402
from mission.logs.writer import RunLogWriter  # noqa: E402


def test_live_client_gets_advertised_channels_and_messages(tmp_path):
    server = LiveServer(port=0)
    assert server.url.startswith("ws://127.0.0.1:")
    writer = RunLogWriter(tmp_path / "live.mcap", live=server)
    try:
        with connect(server.url, subprotocols=["foxglove.sdk.v1"], open_timeout=10) as ws:
            advertised: dict[str, dict] = {}
            deadline = time.monotonic() + 10
            while len(advertised) < len(CHANNELS) and time.monotonic() < deadline:
                msg = json.loads(ws.recv(timeout=5))
                if msg["op"] == "advertise":
                    advertised.update({c["topic"]: c for c in msg["channels"]})
            assert set(advertised) == set(CHANNELS)
            cmd = advertised["/vehicle/command"]
            assert cmd["encoding"] == "json" and cmd["schemaEncoding"] == "jsonschema"
            assert json.loads(cmd["schema"])["title"] == "VehicleCommand"
            ws.send(json.dumps({"op": "subscribe", "subscriptions": [{"id": 5, "channelId": cmd["id"]}]}))
            deadline = time.monotonic() + 10
            while not server._channels["/vehicle/command"].has_sinks():
                assert time.monotonic() < deadline, "subscription never arrived"
                time.sleep(0.01)
            writer.write("/events", 0.5, {"kind": "x", "level": "info", "message": "not subscribed", "fields": {}})
            for k in range(3):
                writer.write("/vehicle/command", 1.0 + k, {"body_velocity": [0.1 * k, 0, 0, 0, 0, 0]})
            got = []
            while len(got) < 3:
                frame = ws.recv(timeout=5)
                assert isinstance(frame, bytes)
                op, sub, ts = struct.unpack("<BIQ", frame[:13])
                assert op == 1 and sub == 5
                got.append((ts, json.loads(frame[13:])))
    finally:
        writer.close()
    assert [ts for ts, _ in got] == [1_000_000_000, 2_000_000_000, 3_000_000_000]
    assert got[2][1] == {"body_velocity": [0.2, 0, 0, 0, 0, 0], "t": 3.0}
    assert read_log(tmp_path / "live.mcap").messages("/vehicle/command") == [m for _, m in got]
