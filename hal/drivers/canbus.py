"""One CAN bus for all CANopen devices (arm and gripper share it).

:class:`CanopenBus` opens the python-can bus, wraps it in :class:`EchoFilterBus`,
produces the host's own heartbeat (the drives consume it through 0x1016 and
fault if the host dies), optionally the SYNC message at ``sync_period`` (for
drives whose TPDOs are sent on SYNC), and runs one service thread that calls every registered drive's
``service(now)`` at a fixed period: heartbeat watchdog, CiA 402 state-machine
stepping and RPDO transmission all happen there, so device methods called from a
control tick only store values and never block.

Some transports (python-can ``udp_multicast``, SocketCAN with
``receive_own_messages``) hand a process its own frames back. In CANopen every
COB-ID has a single producer, so a frame whose ID this process has sent is an
echo: :class:`EchoFilterBus` drops it, otherwise canopen would overwrite PDO
data with what we sent ourselves.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from typing import Any, Protocol

import can
import canopen
from canopen.network import PeriodicMessageTask

from hal.drivers.realtime import STEP_GATE

log = logging.getLogger(__name__)

#: Receive timeout (s) of canopen's notifier thread; bounds how long closing the bus takes.
NOTIFIER_CYCLE = 0.1
#: Period (s) of this computer's heartbeat; drives watching it need a timeout well above it.
HOST_HEARTBEAT_PERIOD = 0.05


class EchoFilterBus(can.BusABC):
    """Wraps a python-can bus and drops received frames with IDs this process sent."""

    def __init__(self, inner: can.BusABC) -> None:
        self._inner = inner
        self._sent_ids: set[int] = set()
        super().__init__(channel=getattr(inner, "channel_info", "echo-filter"))
        self.channel_info = f"echo-filtered {getattr(inner, 'channel_info', inner)}"

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        self._sent_ids.add(msg.arbitration_id)
        self._inner.send(msg, timeout)

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        msg = self._inner.recv(timeout)
        if msg is None:
            return None, False
        STEP_GATE.wait()  # canopen decodes it in this thread: after the loop's step, not during it
        if msg.arbitration_id in self._sent_ids:
            return None, False
        return msg, False

    def shutdown(self) -> None:
        super().shutdown()
        self._inner.shutdown()


def open_can_bus(interface: str, channel: str, **options: Any) -> can.BusABC:
    """Open a python-can bus with the echo filter. For ``udp_multicast`` the hop
    limit defaults to 0 so frames never leave this host."""
    if interface == "udp_multicast":
        options.setdefault("hop_limit", 0)
    return EchoFilterBus(can.Bus(interface=interface, channel=channel, **options))


class Serviced(Protocol):
    def service(self, now: float) -> None: ...


class CanopenBus:
    """A canopen Network on one bus plus the periodic service thread.

    clock: callable giving the backend time (s). period: service period (s).
    """

    def __init__(
        self,
        bus: can.BusABC,
        clock: Callable[[], float],
        period: float = 0.01,
        host_node_id: int = 127,
        host_heartbeat_period: float = HOST_HEARTBEAT_PERIOD,
        sync_period: float | None = None,
    ) -> None:
        self.network = canopen.Network(bus)
        self.network.NOTIFIER_CYCLE = NOTIFIER_CYCLE
        self.network.connect()
        #: Our own node ID; drives watch its heartbeat (0x1016) and stop if we die.
        self.host_node_id = host_node_id
        self._host_heartbeat: PeriodicMessageTask | None = self.network.send_periodic(
            0x700 + host_node_id, bytes([0x05]), host_heartbeat_period
        )
        #: SYNC period (s) this host produces, None when it produces no SYNC.
        self.sync_period = sync_period
        if sync_period:
            self.network.sync.start(sync_period)
        self._clock = clock
        self._period = period
        self._drives: list[Serviced] = []
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.service_errors = 0

    def register(self, drive: Serviced) -> None:
        with self._lock:
            self._drives.append(drive)
        if self._thread is None:
            self._thread = threading.Thread(target=self._run, name="canopen-service", daemon=True)
            self._thread.start()

    def unregister(self, drive: Serviced) -> None:
        with self._lock:
            if drive in self._drives:
                self._drives.remove(drive)

    def _run(self) -> None:
        while not self._stop.wait(self._period):
            with self._lock:
                drives = list(self._drives)
            STEP_GATE.wait()  # the RPDOs go out after the loop's step (its commands are fresh then)
            now = self._clock()
            for d in drives:
                try:
                    d.service(now)
                except Exception:  # noqa: BLE001 - one drive must not stop the others' service
                    self.service_errors += 1
                    log.exception("CANopen service of %r failed", d)

    def stop_host_heartbeat(self) -> None:
        """Stop producing our heartbeat (on close; tests use it to play a crashed host)."""
        if self._host_heartbeat is not None:
            self._host_heartbeat.stop()
            self._host_heartbeat = None

    def close(self) -> None:
        """Stop SYNC, the heartbeat and the service thread, release the bus. Idempotent.
        (Devices release their drives first: see CanopenArm.disconnect.)"""
        if self.sync_period:
            self.network.sync.stop()
            self.sync_period = None
        self.stop_host_heartbeat()
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=1.0)
        try:
            self.network.disconnect()
        except Exception:  # noqa: BLE001
            log.exception("closing the CAN bus failed")
