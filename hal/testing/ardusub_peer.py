"""An ArduSub-like MAVLink peer for tests and dry runs without a vehicle.

    python -m hal.testing.ardusub_peer --url udpout:127.0.0.1:14550 [--heartbeat-rate 5]

Behaves like ArduSub towards a ground station: HEARTBEAT as MAV_TYPE_SUBMARINE
/ MAV_AUTOPILOT_ARDUPILOTMEGA with the armed flag and the Sub custom mode,
ATTITUDE (20 Hz), LOCAL_POSITION_NED and VFR_HUD (10 Hz), DISTANCE_SENSOR
(downward, 5 Hz); COMMAND_LONG arm/disarm and SET_MODE are acknowledged and
applied; SET_POSITION_TARGET_LOCAL_NED velocity setpoints (BODY frames, GUIDED
mode) and MANUAL_CONTROL sticks (MANUAL/STABILIZE/ALT_HOLD; full stick 1 m/s,
0.5 rad/s) move a kinematic vehicle when armed, and are dropped to zero after 1 s
without a new one (like ArduSub's guided timeout).

stdin, one JSON object per line: ``{"cmd": "silence"}`` (stop all output, as
if the tether were cut), ``{"cmd": "resume"}``, ``{"cmd": "quit"}``.
Prints ``READY`` once sending.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import threading
import time

from pymavlink import mavutil

MAV = mavutil.mavlink
SEABED_DEPTH = 12.0  # m


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--url", required=True)
    ap.add_argument("--heartbeat-rate", type=float, default=1.0, help="Hz")
    ap.add_argument("--max-runtime", type=float, default=300.0)
    args = ap.parse_args(argv)
    conn = mavutil.mavlink_connection(args.url, source_system=1, source_component=1, dialect="ardupilotmega")
    state = {"armed": False, "mode": 19, "silent": False, "quit": False}
    pos = [0.0, 0.0, 2.0]
    att = [0.0, 0.0, 0.0]
    sp = {"v": (0.0, 0.0, 0.0, 0.0), "t": -1e9}
    lock = threading.Lock()

    def commands() -> None:
        for line in sys.stdin:
            try:
                cmd = json.loads(line).get("cmd")
            except (json.JSONDecodeError, AttributeError):
                continue
            with lock:
                if cmd == "silence":
                    state["silent"] = True
                elif cmd == "resume":
                    state["silent"] = False
                elif cmd == "quit":
                    break
        state["quit"] = True

    threading.Thread(target=commands, daemon=True).start()
    t0 = time.monotonic()
    last = {"hb": -1e9, "att": -1e9, "pos": -1e9, "rng": -1e9}
    prev = t0
    print("READY", flush=True)
    while not state["quit"] and time.monotonic() - t0 < args.max_runtime:
        msg = conn.recv_match(blocking=True, timeout=0.01)
        now = time.monotonic()
        with lock:
            silent = state["silent"]
            if msg is not None and not silent:
                kind = msg.get_type()
                if kind == "COMMAND_LONG" and msg.command == MAV.MAV_CMD_COMPONENT_ARM_DISARM:
                    state["armed"] = msg.param1 > 0.5
                    conn.mav.command_ack_send(msg.command, MAV.MAV_RESULT_ACCEPTED)
                elif kind == "SET_MODE":
                    state["mode"] = msg.custom_mode
                elif kind == "SET_POSITION_TARGET_LOCAL_NED" and msg.coordinate_frame in (MAV.MAV_FRAME_BODY_NED, MAV.MAV_FRAME_BODY_OFFSET_NED):
                    if state["mode"] == 4:
                        sp["v"], sp["t"] = (msg.vx, msg.vy, msg.vz, msg.yaw_rate), now
                elif kind == "MANUAL_CONTROL" and state["mode"] in (0, 2, 19):
                    # full stick = 1 m/s and 0.5 rad/s in this peer; z 500 is neutral, up positive
                    sp["v"], sp["t"] = (msg.x / 1000.0, msg.y / 1000.0, (500 - msg.z) / 500.0, msg.r / 1000.0 * 0.5), now
            dt, prev = now - prev, now
            u, v, w, r = sp["v"] if now - sp["t"] < 1.0 and state["armed"] else (0.0, 0.0, 0.0, 0.0)
            yaw = att[2]
            pos[0] += (u * math.cos(yaw) - v * math.sin(yaw)) * dt
            pos[1] += (u * math.sin(yaw) + v * math.cos(yaw)) * dt
            pos[2] = min(SEABED_DEPTH - 0.2, max(0.0, pos[2] + w * dt))
            att[2] = math.atan2(math.sin(yaw + r * dt), math.cos(yaw + r * dt))
            if silent:
                continue
            ms = int((now - t0) * 1000)
            if now - last["hb"] >= 1.0 / args.heartbeat_rate:
                last["hb"] = now
                base = MAV.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | (MAV.MAV_MODE_FLAG_SAFETY_ARMED if state["armed"] else 0)
                conn.mav.heartbeat_send(MAV.MAV_TYPE_SUBMARINE, MAV.MAV_AUTOPILOT_ARDUPILOTMEGA, base, state["mode"], MAV.MAV_STATE_ACTIVE)
            if now - last["att"] >= 0.05:
                last["att"] = now
                conn.mav.attitude_send(ms, att[0], att[1], att[2], 0.0, 0.0, r)
            if now - last["pos"] >= 0.1:
                last["pos"] = now
                vn = u * math.cos(yaw) - v * math.sin(yaw)
                ve = u * math.sin(yaw) + v * math.cos(yaw)
                conn.mav.local_position_ned_send(ms, pos[0], pos[1], pos[2], vn, ve, w)
                conn.mav.vfr_hud_send(0.0, math.hypot(vn, ve), int(math.degrees(yaw)) % 360, 0, -pos[2], -w)
            if now - last["rng"] >= 0.2:
                last["rng"] = now
                conn.mav.distance_sensor_send(ms, 20, 5000, int((SEABED_DEPTH - pos[2]) * 100), 0, 1, MAV.MAV_SENSOR_ROTATION_PITCH_270, 0)
    conn.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
