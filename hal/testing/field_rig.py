"""A whole field set-up of protocol peers, for tests and benchmarks that run the
real drivers (``maris run``, ``build_backend``) against them.

The peers, each its own process: ten CiA 402 drives on host-only CAN
(``udp_multicast`` on :data:`~hal.testing.peers.CAN_GROUP`, hop limit 0; arm
joints on nodes 1-7, gripper motors on 10-12), an ArduSub-like MAVLink vehicle
on 127.0.0.1 TCP, a Water Linked DVL over TCP and a MicroStrain AHRS on a
pseudo-terminal; on request a Blue Robotics Ping echosounder over UDP
(:mod:`hal.testing.ping_peer`). :meth:`FieldRig.write_config` writes the HAL config that drives
them with the shipped minimal CiA 402 EDS.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from hal.testing.peers import CAN_GROUP, ROOT, Peer, free_tcp_port, free_udp_port

#: The arm joints of the shipped URDF (kcl/data/r2_uma.urdf), nodes 1-7 in this order.
URDF_JOINTS = (
    "j1_shoulder_yaw",
    "j2_shoulder_pitch",
    "j3_upper_arm_roll",
    "j4_elbow_pitch",
    "j5_forearm_roll",
    "j6_wrist_pitch",
    "j7_wrist_roll",
)

EDS = ROOT / "hal" / "data" / "cia402_minimal.eds"


@dataclass
class FieldRig:
    """The running peers (``can``, ``mav``, ``dvl``, ``ahrs``, and ``ping`` if asked for) and their ports."""

    peers: dict[str, Peer]
    can_port: int
    mav_port: int

    @classmethod
    def start(
        cls, max_runtime: float = 120.0, dvl_rate_hz: float = 10.0, ahrs_rate_hz: float = 50.0, ping: bool = False
    ) -> FieldRig:
        """Start every peer (``max_runtime`` s: each exits by itself after it), with a Ping
        echosounder if ``ping``; the ones already started are stopped if a later one fails."""
        can_port, mav_port = free_udp_port(), free_tcp_port()
        peers: dict[str, Peer] = {}
        try:
            peers["can"] = Peer(
                "hal.testing.cia402_sim",
                "--channel",
                CAN_GROUP,
                "--port",
                str(can_port),
                "--nodes",
                "1,2,3,4,5,6,7,10,11,12",
                max_runtime=max_runtime,
            )
            peers["mav"] = Peer(
                "hal.testing.ardusub_peer", "--url", f"tcpin:127.0.0.1:{mav_port}", max_runtime=max_runtime
            )
            peers["dvl"] = Peer(
                "hal.testing.nav_sensor_sim",
                "dvl-tcp",
                "--rate",
                f"{dvl_rate_hz:g}",
                "--velocity",
                "0.0,0.0,0.0",
                max_runtime=max_runtime,
            )
            peers["ahrs"] = Peer(
                "hal.testing.nav_sensor_sim", "ahrs-serial", "--rate", f"{ahrs_rate_hz:g}", max_runtime=max_runtime
            )
            if ping:
                peers["ping"] = Peer(
                    "hal.testing.ping_peer", "--transport", "udp", "--altitude", "2.0", max_runtime=max_runtime
                )
        except Exception:
            for p in peers.values():
                p.stop()
            raise
        return cls(peers, can_port, mav_port)

    def stop(self) -> None:
        for p in self.peers.values():
            p.stop()

    def write_config(self, path: Path) -> Path:
        """Write the HAL config (YAML) of these peers to ``path``; returns it."""
        ping = (
            f"    ping: {{transport: udp, host: 127.0.0.1, port: {int(self.peers['ping'].ready)}, timeout: 0.5}}\n"
            if "ping" in self.peers
            else ""
        )
        joints = "\n".join(f"      - {{name: {n}, node_id: {i + 1}}}" for i, n in enumerate(URDF_JOINTS))
        # the drives' data and heartbeat limits wider than a real drive's defaults (0.2 s, 0.3 s):
        # ten drives, four other peers and the run share a test machine's two cores, where a
        # process is sometimes not scheduled for 0.2 s (the drivers' own tests keep the defaults)
        can_margins = "stale_timeout: 0.5\n    heartbeat_timeout: 0.6"
        path.write_text(f"""\
buses:
  can0: {{interface: udp_multicast, channel: "{CAN_GROUP}", port: {self.can_port}}}
devices:
  vehicle:
    driver: ardusub
    url: "tcp:127.0.0.1:{self.mav_port}"
    dvl: {{transport: tcp, host: 127.0.0.1, port: {int(self.peers["dvl"].ready)}, timeout: 0.5}}
    ahrs: {{transport: serial, device: {self.peers["ahrs"].ready}, timeout: 0.2}}
{ping}  arm:
    driver: canopen_arm
    bus: can0
    eds: {EDS}
    {can_margins}
    joints:
{joints}
  gripper:
    driver: canopen_gripper
    bus: can0
    eds: {EDS}
    {can_margins}
    motors: {{distal: {{node_id: 10}}, proximal: {{node_id: 11}}, palm: {{node_id: 12}}}}
""")
        return path
