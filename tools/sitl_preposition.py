"""Put ArduSub SITL's vehicle into the pool before a run: GUIDED at the surface to a
point north/east of the EKF origin (the world origin of the ArduSub driver, a corner
of the pool), then disarmed. SITL starts at that origin, on the geofence's edge.

    python tools/sitl_preposition.py tcp:127.0.0.1:5760 2.75 4.0
"""

from __future__ import annotations

import sys
import time

from pymavlink import mavutil

SET_MESSAGE_INTERVAL, DO_SET_MODE, ARM_DISARM = 511, 176, 400
GUIDED = 4  # ArduSub's custom mode number
POSITION_ONLY = 0b110111111000  # SET_POSITION_TARGET_LOCAL_NED type mask: x, y, z only
EKF_POS_HORIZ_ABS, EKF_POS_HORIZ_REL = 0x10, 0x08


def main(url: str, north: float, east: float, depth: float = 0.3) -> int:
    m = mavutil.mavlink_connection(url, source_system=255)
    m.wait_heartbeat(timeout=30)
    for msg_id in (32, 33, 193):  # LOCAL_POSITION_NED, GLOBAL_POSITION_INT, EKF_STATUS_REPORT at 5 Hz
        m.mav.command_long_send(1, 0, SET_MESSAGE_INTERVAL, 0, msg_id, 200000, 0, 0, 0, 0, 0)
    t0 = time.time()
    while True:  # the EKF needs SITL's GPS for a horizontal position
        e = m.recv_match(type="EKF_STATUS_REPORT", blocking=True, timeout=2)
        if e is not None and e.flags & EKF_POS_HORIZ_ABS and e.flags & EKF_POS_HORIZ_REL:
            break
        if time.time() - t0 > 180:
            print("the EKF has no horizontal position after 180 s", file=sys.stderr)
            return 1
    print(f"EKF position after {time.time() - t0:.1f} s", flush=True)
    time.sleep(3)
    m.mav.command_long_send(1, 0, DO_SET_MODE, 0, 1, GUIDED, 0, 0, 0, 0, 0)
    time.sleep(1)
    armed = False
    for _ in range(10):
        m.mav.command_long_send(1, 0, ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
        hb = m.recv_match(type="HEARTBEAT", blocking=True, timeout=2)
        armed = hb is not None and bool(hb.base_mode & 0x80)
        if armed:
            break
        time.sleep(1)
    if not armed:
        print("SITL did not arm", file=sys.stderr)
        return 1
    t1, pos = time.time(), None
    while time.time() - t1 < 120:
        m.mav.heartbeat_send(6, 8, 0, 0, 0)  # a ground station's heartbeat (FS_GCS_ENABLE)
        m.mav.set_position_target_local_ned_send(0, 1, 1, 1, POSITION_ONLY, north, east, depth, 0, 0, 0, 0, 0, 0, 0, 0)
        msg = m.recv_match(type="LOCAL_POSITION_NED", blocking=True, timeout=0.5)
        if msg is not None:
            pos = (round(msg.x, 2), round(msg.y, 2), round(msg.z, 2))
            if abs(msg.x - north) < 0.15 and abs(msg.y - east) < 0.15:
                break
        time.sleep(0.2)
    print(f"at {pos} after {time.time() - t1:.1f} s; disarming", flush=True)
    m.mav.command_long_send(1, 0, ARM_DISARM, 0, 0, 0, 0, 0, 0, 0, 0)
    time.sleep(1)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], float(sys.argv[2]), float(sys.argv[3])))
