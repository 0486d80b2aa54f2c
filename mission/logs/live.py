"""Live view of a run in Foxglove: the run-log channels over a WebSocket.

:class:`LiveServer` speaks the Foxglove WebSocket protocol, under both names a
client may ask for: ``foxglove.websocket.v1`` (Foxglove Studio 1.x, Lichtblick)
and ``foxglove.sdk.v1`` (current Foxglove, the SDK's name for the same
protocol). The protocol is public and small; the WebSocket layer is the
``websockets`` package; the ``foxglove-sdk`` server is not used because it
refuses ``foxglove.websocket.v1`` clients and has no access token.

* Channels: every topic of :mod:`mission.logs.channels` (JSON) and
  :mod:`mission.logs.wellknown` (protobuf), with their schemas.
  :class:`mission.logs.writer.RunLogWriter` hands each encoded message over
  (the bytes of the file); it is queued for each subscribed client and sent by
  that client's thread, so a slow client never slows the control loop (a full
  queue drops its oldest messages; the count is reported).
* Time: the server publishes the run's log time (``time`` capability), so a
  viewer's clock follows the run (simulated time for a dry run) rather than
  the wall clock of the viewer's machine.
* Late joiners: the last message of each :data:`LATCHED` topic (run config,
  sources, supervisor state, device health, scenes, goals, tree...) is sent
  as soon as a client subscribes to it.
* Operator commands: a client publishes ``{"command": "pause"|"resume"|"abort"}``
  (JSON, schema name ``maris.OperatorCommand``) on ``/operator/command`` (the
  Publish panel of the shipped layout), or calls the services
  ``/operator/pause``, ``/operator/resume``, ``/operator/abort``. They go into
  the run's :class:`mission.runtime.operator.CommandQueue`; the supervisor logs
  and obeys them like keys.
* The operator's teleop inputs go into the run's ``foxglove`` operator input
  (:class:`hal.drivers.pushed_input.PushedInput`, :meth:`LiveServer.attach_input`),
  which the supervisor reads like any device: ``geometry_msgs/Twist`` on
  :data:`TWIST_TOPIC` (the Teleop panel; a ``TwistStamped`` is dated by its
  stamp), ``geometry_msgs/PoseStamped`` on
  :data:`POSE_TOPIC` and ``geometry_msgs/PointStamped`` on :data:`POINT_TOPIC`
  (the 3D panel's click-to-publish; ``header.stamp``, the browser's clock, dates
  them), ``{"u", "v", "camera"}`` on :data:`IMAGE_POINT_TOPIC`, and on
  ``/operator/command`` ``{"button": "handback"|"stop"|"frame:toggle"}`` or
  ``{"mode": "<mode>"}`` (Publish panels); the service ``/operator/handback``
  hands control back. All as JSON. A client that disconnects is said to the
  input (its commands then age past the teleop's dead-man).
* ROS profile: Foxglove Studio 1.48's 3D panel publishes clicks only when the
  connection has a ROS profile, which its WebSocket player takes from the
  server's ``ROS_DISTRO`` metadata; the server says ``noetic`` (``ros_profile``)
  and takes the clicks as JSON (its only encoding), so no ROS is involved.
* Security: bound to 127.0.0.1 unless told otherwise; bound to any other
  address it needs an access token, which a client gives as ``?token=`` in the
  URL (``ws://host:port/?token=...``; browsers cannot set headers) or as an
  ``Authorization: Bearer`` header. A wrong or missing token gets HTTP 401.
* Server notices (connections, refusals, drops) are not printed: they are
  queued and :meth:`LiveServer.forward_notices` turns them into run events
  (``live`` kind) in the log, from the supervisor's thread.
"""

from __future__ import annotations

import base64
import hmac
import http
import ipaddress
import json
import logging
import math
import struct
import threading
import urllib.parse
from collections import deque
from typing import TYPE_CHECKING, Any, TypedDict

if TYPE_CHECKING:  # websockets is optional (the `live` extra): imported when a server starts
    from websockets.sync.server import Server

from mission.logs.channels import CHANNELS
from mission.logs.wellknown import WELL_KNOWN

HOST = "127.0.0.1"
SUBPROTOCOLS = ("foxglove.websocket.v1", "foxglove.sdk.v1")
COMMAND_TOPIC = "/operator/command"
COMMAND_SCHEMA = "maris.OperatorCommand"
COMMANDS = ("pause", "resume", "abort")
#: The operator's teleop topics (JSON): the Teleop panel's twist, the 3D panel's clicks, image clicks.
TWIST_TOPIC = "/operator/cmd_vel"
POSE_TOPIC = "/operator/goal_pose"
POINT_TOPIC = "/operator/goal_point"
IMAGE_POINT_TOPIC = "/operator/image_point"
TELEOP_TOPICS = (TWIST_TOPIC, POSE_TOPIC, POINT_TOPIC, IMAGE_POINT_TOPIC)
#: Buttons a client may press on ``/operator/command`` (``{"button": ...}``); modes go as ``{"mode": ...}``.
BUTTONS = ("handback", "stop", "frame:toggle", "mode:next")
#: Services, each a command of the queue, or (``handback``) a press of the operator input.
SERVICES = (*COMMANDS, "handback")
#: topic -> how many last messages a late joiner gets
LATCHED: dict[str, int] = {
    "/run/config": 1,
    "/run/source": 16,
    "/supervisor/state": 1,
    "/devices/health": 1,
    "/tree": 1,
    "/blackboard": 1,
    "/run/result": 1,
    "/scene/robot": 1,
    "/scene/world": 1,
    "/waypoints": 1,
    "/goal/vehicle": 1,
    "/goal/tool": 1,
}
_CLIENT_QUEUE = 4096
#: How often the server tells clients the run's time (``time`` capability), ns of log time.
_TIME_PERIOD_NS = 50_000_000

#: s a closing connection waits for the client's answer: a client that stopped reading
#: does not hold the end of the run (or ``close``) for websockets' default 10 s
CLOSE_TIMEOUT_S = 2.0


def is_loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


class ChannelAdvert(TypedDict):
    """One channel as the Foxglove WebSocket protocol advertises it."""

    id: int
    topic: str
    encoding: str
    schemaName: str
    schema: str
    schemaEncoding: str


def _channel_table() -> list[ChannelAdvert]:
    out: list[ChannelAdvert] = []
    for topic, (name, schema) in CHANNELS.items():
        out.append(
            {
                "id": len(out) + 1,
                "topic": topic,
                "encoding": "json",
                "schemaName": name,
                "schema": json.dumps(schema),
                "schemaEncoding": "jsonschema",
            }
        )
    for topic, cls in WELL_KNOWN.items():
        sch = cls.get_schema()
        out.append(
            {
                "id": len(out) + 1,
                "topic": topic,
                "encoding": sch.encoding,
                "schemaName": sch.name,
                "schema": base64.b64encode(bytes(sch.data)).decode(),
                "schemaEncoding": sch.encoding,
            }
        )
    return out


class _Client:
    """One connected client: its subscriptions, its advertised channels, its send queue."""

    def __init__(self, conn: Any, name: str) -> None:
        self.conn = conn
        self.name = name
        self.subs: dict[int, int] = {}  # subscription id -> channel id
        self.advertised: dict[int, dict] = {}  # client channel id -> channel
        self.queue: deque[bytes | str] = deque(maxlen=_CLIENT_QUEUE)
        self.ready = threading.Condition()
        self.dropped = 0
        self.closed = False

    def push(self, frame: bytes | str) -> None:
        with self.ready:
            if len(self.queue) == self.queue.maxlen:
                self.dropped += 1
            self.queue.append(frame)
            self.ready.notify()


class LiveServer:
    """A Foxglove WebSocket server for one run (see the module docstring).

    ``host``: 127.0.0.1 by default; another address requires ``token``.
    ``port`` 0 picks a free port. ``commands``: where operator commands go
    (None: they are refused with a status message)."""

    def __init__(
        self,
        port: int = 8765,
        *,
        host: str = HOST,
        token: str | None = None,
        commands: Any = None,
        name: str = "maris",
        ros_profile: bool = True,
    ) -> None:
        try:
            from websockets.sync.server import serve  # optional: the `live` extra
            from websockets.typing import Subprotocol
        except ImportError as exc:  # pragma: no cover - depends on the environment
            raise RuntimeError("--live needs the websockets package: pip install 'maris-uvms[live]'") from exc
        if not is_loopback(host) and not token:
            raise ValueError(f"serving on {host} (not this machine only) needs an access token (--live-token)")
        self.host = host
        self.token = token or None
        self.commands = commands
        self.name = name
        self.ros_profile = ros_profile
        #: The run's ``foxglove`` operator input (:meth:`attach_input`), None without one.
        self.operator_input: Any = None
        self._channels = _channel_table()
        self._by_topic = {ch["topic"]: ch["id"] for ch in self._channels}
        self._lock = threading.Lock()
        self._clients: list[_Client] = []
        #: channel id -> clients subscribed (with their subscription id); read lock-free by publish()
        self._subscribers: dict[int, list[tuple[_Client, int]]] = {}
        self._latched: dict[int, deque[tuple[int, bytes]]] = {
            self._by_topic[t]: deque(maxlen=n) for t, n in LATCHED.items() if t in self._by_topic
        }
        self._next_time_ns = 0
        self._services = [
            {"id": i + 1, "name": f"/operator/{c}", "type": COMMAND_SCHEMA, "command": c}
            for i, c in enumerate(SERVICES)
        ]
        self.notices: deque[tuple[str, str]] = deque(maxlen=256)
        quiet = logging.getLogger(f"maris.live.{id(self)}")
        quiet.propagate = False
        quiet.addHandler(_NoticeHandler(self.notices))
        quiet.setLevel(logging.WARNING)
        self._server: Server | None = serve(
            self._handle,
            host,
            port,
            subprotocols=[Subprotocol(p) for p in SUBPROTOCOLS],
            process_request=self._check_request,
            logger=quiet,
            compression=None,
            close_timeout=CLOSE_TIMEOUT_S,
        )
        self.port: int = self._server.socket.getsockname()[1]
        self._thread = threading.Thread(target=self._server.serve_forever, name="maris-live", daemon=True)
        self._thread.start()

    # -------------------------------------------------------------- public
    def attach_input(self, device: Any) -> None:
        """Feed the operator's teleop messages into ``device`` (the run's ``foxglove``
        operator input: a :class:`hal.drivers.pushed_input.PushedInput`), from now on."""
        self.operator_input = device
        with self._lock:
            clients = len(self._clients)
        for _ in range(clients):
            device.link(True, "Foxglove client")

    @property
    def url(self) -> str:
        """The address to open in Foxglove (with the token when there is one)."""
        host = f"[{self.host}]" if ":" in self.host else self.host
        base = f"ws://{host}:{self.port}"
        return base + (f"/?token={urllib.parse.quote(self.token)}" if self.token else "")

    def publish(self, topic: str, log_time_ns: int, data: bytes) -> None:
        """Hand one encoded message to the subscribed clients (and the latch)."""
        cid = self._by_topic.get(topic)
        if cid is None:
            return
        latch = self._latched.get(cid)
        if latch is not None:
            latch.append((log_time_ns, data))
        subs = self._subscribers.get(cid)
        if subs:
            for client, sub_id in subs:
                client.push(struct.pack("<BIQ", 1, sub_id, log_time_ns) + data)
        if log_time_ns >= self._next_time_ns and self._clients:
            self._next_time_ns = log_time_ns + _TIME_PERIOD_NS
            frame = struct.pack("<BQ", 2, log_time_ns)
            for client in list(self._clients):
                client.push(frame)

    def forward_notices(self, events: Any) -> None:
        """Emit queued server notices as ``live`` events on ``events`` (an
        :class:`mission.runtime.context.EventSink`); call from the run's thread."""
        while self.notices:
            level, text = self.notices.popleft()
            events.emit("live", text, level=level)

    def close(self) -> None:
        """Stop serving and disconnect every client. Idempotent."""
        server, self._server = self._server, None
        if server is None:
            return
        server.shutdown()
        with self._lock:
            clients = list(self._clients)
        for c in clients:
            self._drop(c)
            try:
                c.conn.close()
            except Exception:  # noqa: BLE001 - already gone
                pass
        self._thread.join(timeout=5)

    # ------------------------------------------------------------ handshake
    def _check_request(self, conn: Any, request: Any) -> Any:
        if self.token is None:
            return None
        query = urllib.parse.parse_qs(urllib.parse.urlparse(request.path).query)
        given = (query.get("token") or [""])[0]
        auth = request.headers.get("Authorization", "")
        if auth.lower().startswith("bearer "):
            given = given or auth[7:].strip()
        if given and hmac.compare_digest(given.encode(), self.token.encode()):
            return None
        peer = _peer(conn)
        self.notices.append(("warning", f"refused a client from {peer}: {'wrong' if given else 'no'} access token"))
        return conn.respond(http.HTTPStatus.UNAUTHORIZED, "access token required\n")

    # ----------------------------------------------------------- per client
    def _handle(self, conn: Any) -> None:
        client = _Client(conn, _peer(conn))
        with self._lock:
            self._clients.append(client)
        self.notices.append(("info", f"Foxglove client connected from {client.name} ({conn.subprotocol})"))
        if self.operator_input is not None:
            self.operator_input.link(True, f"Foxglove client {client.name}")
        sender = threading.Thread(target=self._send_loop, args=(client,), name="maris-live-send", daemon=True)
        sender.start()
        client.push(
            json.dumps(
                {
                    "op": "serverInfo",
                    "name": self.name,
                    "capabilities": ["clientPublish", "services", "time"],
                    "supportedEncodings": ["json"],
                    "metadata": self._metadata(),
                    "sessionId": str(id(self)),
                }
            )
        )
        client.push(json.dumps({"op": "advertise", "channels": self._channels}))
        client.push(
            json.dumps({"op": "advertiseServices", "services": [self._service_json(s) for s in self._services]})
        )
        try:
            for frame in conn:
                if isinstance(frame, str):
                    self._on_text(client, frame)
                else:
                    self._on_binary(client, frame)
        except Exception as exc:  # noqa: BLE001 - connection errors end this client only
            self.notices.append(("warning", f"Foxglove client {client.name}: {type(exc).__name__}: {exc}"))
        finally:
            self._drop(client)
            if self.operator_input is not None:  # its commands stop: the teleop's dead-man stops the motion
                self.operator_input.link(False, f"Foxglove client {client.name}")
            sender.join(timeout=2)
            dropped = f", {client.dropped} messages dropped (slow link)" if client.dropped else ""
            self.notices.append(("info", f"Foxglove client {client.name} disconnected{dropped}"))

    def _send_loop(self, client: _Client) -> None:
        while True:
            with client.ready:
                while not client.queue and not client.closed:
                    client.ready.wait(0.5)
                if client.closed and not client.queue:
                    return
                frames = list(client.queue)
                client.queue.clear()
            try:
                for f in frames:
                    client.conn.send(f)
            except Exception:  # noqa: BLE001 - the reader side reports the disconnect
                return

    def _drop(self, client: _Client) -> None:
        with self._lock:
            if client in self._clients:
                self._clients.remove(client)
            self._rebuild()
        with client.ready:
            client.closed = True
            client.ready.notify()

    def _rebuild(self) -> None:
        """Recompute channel -> subscribers (under the lock; publish reads the new dict)."""
        table: dict[int, list[tuple[_Client, int]]] = {}
        for c in self._clients:
            for sub_id, cid in c.subs.items():
                table.setdefault(cid, []).append((c, sub_id))
        self._subscribers = table

    def _status(self, client: _Client, level: int, message: str) -> None:
        client.push(json.dumps({"op": "status", "level": level, "message": message}))

    def _on_text(self, client: _Client, frame: str) -> None:
        try:
            msg = json.loads(frame)
            op = msg["op"]
        except (ValueError, KeyError, TypeError):
            self._status(client, 2, "malformed message")
            return
        if op == "subscribe":
            new = []
            with self._lock:
                for s in msg.get("subscriptions", []):
                    sub_id, cid = int(s["id"]), int(s["channelId"])
                    if not any(ch["id"] == cid for ch in self._channels):
                        self._status(client, 1, f"no channel {cid}")
                        continue
                    client.subs[sub_id] = cid
                    new.append((sub_id, cid))
                    # the latched values go out before any newer message of this channel
                    for ns, data in list(self._latched.get(cid, ())):
                        client.push(struct.pack("<BIQ", 1, sub_id, ns) + data)
                self._rebuild()
        elif op == "unsubscribe":
            with self._lock:
                for sub_id in msg.get("subscriptionIds", []):
                    client.subs.pop(int(sub_id), None)
                self._rebuild()
        elif op == "advertise":
            for ch in msg.get("channels", []):
                client.advertised[int(ch["id"])] = ch
        elif op == "unadvertise":
            for cid in msg.get("channelIds", []):
                client.advertised.pop(int(cid), None)
        else:
            self._status(client, 1, f"operation {op!r} is not supported by this server")

    def _on_binary(self, client: _Client, frame: bytes) -> None:
        if not frame:
            return
        if frame[0] == 1 and len(frame) >= 5:  # client message data
            (cid,) = struct.unpack_from("<I", frame, 1)
            ch = client.advertised.get(cid)
            if ch is None:
                self._status(client, 1, f"message on unadvertised channel {cid}")
                return
            topic = ch.get("topic")
            if topic != COMMAND_TOPIC and topic not in TELEOP_TOPICS:
                self._status(
                    client, 1, f"this server takes messages only on {COMMAND_TOPIC}, {', '.join(TELEOP_TOPICS)}"
                )
                return
            try:
                msg = json.loads(bytes(frame[5:]))
            except ValueError:
                self._status(client, 2, f"{topic}: not JSON (this server takes JSON messages)")
                return
            if topic == COMMAND_TOPIC:
                self._on_command_message(client, msg)
            else:
                self._teleop(client, str(topic), msg)
        elif frame[0] == 2 and len(frame) >= 13:  # service call request
            service_id, call_id, enc_len = struct.unpack_from("<III", frame, 1)
            encoding = bytes(frame[13 : 13 + enc_len]).decode(errors="replace")
            service = next((s for s in self._services if s["id"] == service_id), None)
            if service is None:
                self._status(client, 2, f"no service {service_id}")
                return
            if service["command"] == "handback":
                ok = self._press(client, "service:handback")
            else:
                ok = self._command(client, service["command"])
            reply = json.dumps({"accepted": ok, "command": service["command"]}).encode()
            enc = encoding.encode() or b"json"
            client.push(struct.pack("<BIII", 3, service_id, call_id, len(enc)) + enc + reply)
        else:
            self._status(client, 1, f"binary opcode {frame[0]} is not supported")

    def _metadata(self) -> dict[str, str]:
        meta = {
            "commands": f'publish {{"command": ...}} on {COMMAND_TOPIC}',
            "teleop": f"Twist on {TWIST_TOPIC}, PoseStamped on {POSE_TOPIC}, PointStamped on {POINT_TOPIC}",
        }
        if self.ros_profile:  # Studio 1.48's 3D panel publishes clicks in a ROS profile only
            meta["ROS_DISTRO"] = "noetic"
        return meta

    def _on_command_message(self, client: _Client, msg: Any) -> None:
        if isinstance(msg, dict) and "button" in msg:
            button = msg["button"]
            if button not in BUTTONS:
                self._status(client, 2, f"unknown button {button!r}; known: {', '.join(BUTTONS)}")
                return
            self._press(client, str(button))
        elif isinstance(msg, dict) and "mode" in msg:
            self._press(client, f"mode:{msg['mode']}")
        elif isinstance(msg, dict) and "command" in msg:
            self._command(client, msg["command"])
        else:
            self._status(
                client,
                2,
                f'{COMMAND_TOPIC} expects {{"command": "pause"|"resume"|"abort"}}, {{"button": ...}} or {{"mode": ...}}',
            )

    def _press(self, client: _Client, button: str) -> bool:
        if self.operator_input is None:
            self._status(client, 1, "this run has no foxglove operator input (HAL role `foxglove`)")
            return False
        self.operator_input.press(button)
        return True

    def _teleop(self, client: _Client, topic: str, msg: Any) -> None:
        """One teleop message into the operator input (see the module docstring)."""
        device = self.operator_input
        if device is None:
            self._status(client, 1, "this run has no foxglove operator input (HAL role `foxglove`)")
            return
        try:
            if topic == TWIST_TOPIC:  # a Twist (the Teleop panel), or a TwistStamped (dated by its stamp)
                twist = msg.get("twist", msg)
                lin, ang = twist["linear"], twist["angular"]
                values = [lin["x"], lin["y"], lin["z"], ang["x"], ang["y"], ang["z"]]
                device.push_velocity(values, sent=_stamp(msg))
            elif topic == POSE_TOPIC:
                pose = msg["pose"]
                p, o = pose["position"], pose["orientation"]
                T = _pose_matrix((p["x"], p["y"], p["z"]), (o["x"], o["y"], o["z"], o["w"]))
                device.push_pose(T, _frame(msg), sent=_stamp(msg))
            elif topic == POINT_TOPIC:
                p = msg["point"]
                device.push_point((p["x"], p["y"], p["z"]), _frame(msg), sent=_stamp(msg))
            else:
                device.push_image_point((msg["u"], msg["v"]), str(msg.get("camera", "left")), sent=_stamp(msg))
        except (KeyError, TypeError, ValueError) as exc:
            self._status(client, 2, f"{topic}: cannot read the message ({type(exc).__name__}: {exc})")

    def _command(self, client: _Client, command: Any) -> bool:
        if command not in COMMANDS:
            self._status(client, 2, f"unknown command {command!r}; known: {', '.join(COMMANDS)}")
            return False
        if self.commands is None:
            self._status(client, 1, "this run takes no operator commands")
            return False
        self.commands.put(str(command), f"Foxglove client {client.name}")
        return True

    @staticmethod
    def _service_json(s: dict) -> dict:
        """A service in both the current (``request``/``response``) and the older
        (``requestSchema``/``responseSchema``) forms of the protocol."""
        request = json.dumps({"type": "object", "properties": {}})
        reply = json.dumps(
            {"type": "object", "properties": {"accepted": {"type": "boolean"}, "command": {"type": "string"}}}
        )
        return {
            "id": s["id"],
            "name": s["name"],
            "type": s["type"],
            "request": {
                "encoding": "json",
                "schemaName": COMMAND_SCHEMA,
                "schemaEncoding": "jsonschema",
                "schema": request,
            },
            "response": {
                "encoding": "json",
                "schemaName": "maris.OperatorReply",
                "schemaEncoding": "jsonschema",
                "schema": reply,
            },
            "requestSchema": request,
            "responseSchema": reply,
        }


def _frame(msg: dict) -> str:
    return str((msg.get("header") or {}).get("frame_id", ""))


def _stamp(msg: dict) -> float | None:
    """``header.stamp`` in s (ROS 1 ``sec``/``nsec``, ROS 2 ``sec``/``nanosec``); None when absent or zero."""
    stamp = (msg.get("header") or {}).get("stamp") or {}
    if not isinstance(stamp, dict) or "sec" not in stamp:
        return None
    nsec: Any = stamp.get("nsec", stamp.get("nanosec", 0))
    t = float(stamp["sec"]) + 1e-9 * float(nsec)
    return t if t > 0.0 else None


def _pose_matrix(p: tuple, q: tuple) -> list[list[float]]:
    """A 4x4 pose from a position and a quaternion (x, y, z, w; normalised here)."""
    x, y, z, w = (float(v) for v in q)
    n = math.sqrt(x * x + y * y + z * z + w * w)
    if not n > 0.0 or not math.isfinite(n):
        raise ValueError("the orientation is not a quaternion")
    x, y, z, w = x / n, y / n, z / n, w / n
    return [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w), float(p[0])],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w), float(p[1])],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y), float(p[2])],
        [0.0, 0.0, 0.0, 1.0],
    ]


class _NoticeHandler(logging.Handler):
    """websockets' own log lines (handshake failures...) into the notice queue."""

    def __init__(self, notices: deque) -> None:
        super().__init__()
        self.notices = notices

    def emit(self, record: logging.LogRecord) -> None:
        try:
            text = record.getMessage()
        except Exception:  # noqa: BLE001
            text = str(record.msg)
        self.notices.append(("warning" if record.levelno >= logging.WARNING else "info", f"live server: {text}"))


def _peer(conn: Any) -> str:
    try:
        host, port = conn.remote_address[:2]
        return f"{host}:{port}"
    except Exception:  # noqa: BLE001
        return "?"
