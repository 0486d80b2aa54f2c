"""Live view of a run in Foxglove: the run-log channels served over a WebSocket
(Foxglove SDK server, ``foxglove.sdk.v1`` protocol), on 127.0.0.1 only.

:class:`LiveServer` advertises every topic of :mod:`mission.logs.channels`
with its JSON schema; :class:`mission.logs.writer.RunLogWriter` hands it each
encoded message (the same bytes as in the file). Messages go out only while a
client is subscribed, so an idle server costs next to nothing. In Foxglove:
"Open connection" -> ``ws://127.0.0.1:<port>``. Needs the ``foxglove-sdk``
package (the ``live`` extra).
"""

from __future__ import annotations

import json

from mission.logs.channels import CHANNELS

HOST = "127.0.0.1"


class LiveServer:
    """A Foxglove WebSocket server on ``127.0.0.1:port`` (0 = any free port)."""

    def __init__(self, port: int = 8765, name: str = "maris") -> None:
        try:
            import foxglove
        except ImportError as exc:  # pragma: no cover - depends on the environment
            raise RuntimeError("--live needs the foxglove-sdk package: pip install 'maris-uvms[live]'") from exc
        self._context = foxglove.Context()
        self._server = foxglove.start_server(name=name, host=HOST, port=port, context=self._context)
        self.port: int = self._server.port
        self._channels = {
            topic: foxglove.Channel(
                topic,
                schema=foxglove.Schema(name=schema_name, encoding="jsonschema", data=json.dumps(schema).encode()),
                message_encoding="json",
                context=self._context,
            )
            for topic, (schema_name, schema) in CHANNELS.items()
        }

    @property
    def url(self) -> str:
        return f"ws://{HOST}:{self.port}"

    def publish(self, topic: str, log_time_ns: int, data: bytes) -> None:
        """Send one encoded JSON message to the subscribed clients, if any."""
        ch = self._channels.get(topic)
        if ch is not None and ch.has_sinks():
            ch.log(data, log_time=log_time_ns)

    def close(self) -> None:
        """Stop serving. Idempotent."""
        if self._server is not None:
            self._server.stop()
            self._server = None
