"""Three-motor gripper (MARIS hand): distal, proximal and palm groups.

Positions are motor-group angles (rad): fingers 0 = open, ``closed_rad`` = end of
travel; the palm group sets the preshape. Groups move at ``speed_rad_s``.

While closing, the backend tells :meth:`GripperModel.step` whether the pipe is
inside the hand (``contact_possible``). Fingers that reach the pipe's surface
stop there and their motor current rises (first order, ``current_rise_time_s``)
towards the requested current limit; when it is reached the gripper reports
HOLDING (worm gears: the grasp holds). Closing on nothing runs to the end of
travel with only the low running current, then reports STOPPED.
Whether the pipe *stays* in the hand is decided by the backend at the moment of
contact (grasp tolerance); if it slips, the backend calls :meth:`lose_contact`.
"""

from __future__ import annotations

import math

import numpy as np

from hal.interfaces import GripperMotion

#: Palm-group angle (rad) of each preshape.
PRESHAPE_PALM_RAD: dict[str, float] = {"cylindrical": 0.0, "parallel": 0.5, "power": 1.0}
#: Radius (m) of the largest cylinder the open hand surrounds; sets where fingers touch.
HAND_OPEN_RADIUS_M = 0.12
DISTAL, PROXIMAL, PALM = 0, 1, 2


def contact_angle(closed_rad: float, object_radius: float) -> float:
    """Finger angle (rad) at which closing fingers touch a cylinder of ``object_radius`` (m)."""
    frac = 1.0 - object_radius / HAND_OPEN_RADIUS_M
    return closed_rad * min(0.95, max(0.2, frac))


class GripperModel:
    """Motor-group positions, currents and what the hand is doing."""

    def __init__(self, params: dict, object_radius: float):
        self.speed = float(params["gripper.speed_rad_s"])
        self.closed = float(params["gripper.closed_rad"])
        self.idle_current = float(params["gripper.idle_current_a"])
        self.moving_current = float(params["gripper.moving_current_a"])
        self.rise_time = float(params["gripper.current_rise_time_s"])
        self.contact_at = contact_angle(self.closed, object_radius)
        self.positions = np.zeros(3)
        self.targets = np.zeros(3)
        self.current = np.full(3, self.idle_current)
        self.motion = GripperMotion.IDLE
        self.current_limit = 0.0
        self.in_contact = False
        self.fault: str | None = None
        self._settled = False

    # ---------------------------------------------------------------- commands

    def preshape(self, shape: str) -> None:
        self._settled = False
        self.in_contact = False
        self.targets[:] = (0.0, 0.0, PRESHAPE_PALM_RAD[shape])
        self.motion = GripperMotion.PRESHAPING

    def close(self, current_limit: float) -> None:
        self._settled = False
        self.current_limit = float(current_limit)
        self.targets[DISTAL] = self.targets[PROXIMAL] = self.closed
        self.targets[PALM] = self.positions[PALM]
        self.motion = GripperMotion.CLOSING

    def open(self) -> None:
        self._settled = False
        self.in_contact = False
        self.targets[DISTAL] = self.targets[PROXIMAL] = 0.0
        self.targets[PALM] = self.positions[PALM]
        self.motion = GripperMotion.OPENING

    def stop(self) -> None:
        self._settled = False
        self.targets[:] = self.positions
        if self.motion is not GripperMotion.HOLDING:
            self.motion = GripperMotion.STOPPED

    def lose_contact(self) -> None:
        """The object slipped out: fingers go on closing on nothing."""
        self._settled = False
        self.in_contact = False
        if self.motion in (GripperMotion.CLOSING, GripperMotion.HOLDING):
            self.motion = GripperMotion.CLOSING

    # ---------------------------------------------------------------- physics

    @property
    def settled(self) -> bool:
        """Nothing moves or changes until the next command (:meth:`step` is then a no-op
        unless the gripper is faulted)."""
        return self._settled

    @property
    def closing(self) -> bool:
        return self.motion is GripperMotion.CLOSING

    def step(self, h: float, contact_possible: bool) -> bool:
        """Advance ``h`` s. Returns True at the step the fingers first touch the object."""
        if self.fault is not None:
            self.current[:] = 0.0
            return False
        if self._settled:
            return False
        touched = False
        moving = False
        for g in range(3):
            err = self.targets[g] - self.positions[g]
            if err == 0.0:
                continue
            stepv = math.copysign(min(abs(err), self.speed * h), err)
            new = self.positions[g] + stepv
            if (
                g != PALM
                and self.motion is GripperMotion.CLOSING
                and contact_possible
                and self.positions[g] <= self.contact_at < new + 1e-12
            ):
                new = self.contact_at
                self.targets[g] = new
                if not self.in_contact:
                    touched = True
                self.in_contact = True
            self.positions[g] = new
            moving = moving or new != self.targets[g] or stepv != 0.0
        a = 1.0 - math.exp(-h / self.rise_time)
        if self.in_contact and self.motion in (GripperMotion.CLOSING, GripperMotion.HOLDING):
            for g in (DISTAL, PROXIMAL):
                self.current[g] += (self.current_limit - self.current[g]) * a
            self.current[PALM] = self.idle_current
            if self.current[DISTAL] >= 0.98 * self.current_limit:
                self.motion = GripperMotion.HOLDING
        else:
            for g in range(3):
                busy = self.positions[g] != self.targets[g]
                target_current = self.moving_current if busy else self.idle_current
                self.current[g] += (target_current - self.current[g]) * a
            if not moving and self.motion in (GripperMotion.CLOSING, GripperMotion.OPENING, GripperMotion.PRESHAPING):
                self.motion = GripperMotion.STOPPED if self.motion is GripperMotion.CLOSING else GripperMotion.IDLE
            if not moving and abs(self.current - self.idle_current).max() < 1e-6:
                self.current[:] = self.idle_current
                self._settled = True  # nothing changes until the next command
        return touched
