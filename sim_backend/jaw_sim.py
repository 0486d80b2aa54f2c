"""The jaw of a Reach Alpha arm: one motor moving a rod, two fingers (``gripper.model: jaw``).

What the Reach jaw device is and reports (spec section 4; :mod:`hal.drivers.reach_jaw`):
one linear actuator whose rod opening (0 = closed, up to ``jaw.max_opening_mm``)
turns both fingers by ``jaw.finger_rad_per_mm`` per mm, capped at
``jaw.finger_max_rad``; it moves at ``jaw.speed_mm_s``. Its readings, as the
HAL jaw's: one position (the opening, m) and one current (A, positive while
squeezing).

Fingers hinge ``jaw.hinge_y_m`` off the tool's x-z plane; their faces meet when
closed. A cylinder of radius ``r`` centred at the tool point (``jaw.tcp_beyond_hinge_m``
beyond the hinges along the approach) is touched when the half gap there,
``hinge_y (1 - cos a) + tcp_beyond_hinge sin a``, closes to ``r``
(:func:`contact_opening_mm`). Closing on the pipe, the rod stops there and the
current rises towards the requested limit (first order,
``gripper.current_rise_time_s``) while the jaw squeezes: HOLDING once it is
within 2 % of the limit (the device holds the grip by current). Closing on
nothing runs to the closed end with the running current: STOPPED. Whether
the pipe stays is the backend's grasp rule (:mod:`sim_backend.grasp`), as for
the MARIS hand.

Same interface as :class:`sim_backend.gripper_sim.GripperModel`, with one motor group.
"""

from __future__ import annotations

import math

import numpy as np

from hal.interfaces import GripperMotion

#: Preshapes of the simulated jaw, in the order of ``jaw.preshape_mm``.
JAW_PRESHAPES: tuple[str, ...] = ("parallel", "small_pipe")


def half_gap_m(angle: float, hinge_y: float, tcp_beyond_hinge: float) -> float:
    """Half the gap (m) between the finger faces at the tool point, fingers open by ``angle`` (rad)."""
    return hinge_y * (1.0 - math.cos(angle)) + tcp_beyond_hinge * math.sin(angle)


def contact_opening_mm(params: dict, object_radius: float) -> float:
    """Rod opening (mm) at which closing fingers touch a cylinder of ``object_radius``
    (m) centred at the tool point; 0 when the open jaw cannot enclose it."""
    per_mm = float(params["jaw.finger_rad_per_mm"])
    cap = float(params["jaw.finger_max_rad"])
    hy, tcp = float(params["jaw.hinge_y_m"]), float(params["jaw.tcp_beyond_hinge_m"])
    if half_gap_m(cap, hy, tcp) <= object_radius:
        return 0.0
    lo, hi = 0.0, cap  # bisection on the finger angle: the half gap grows with it
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if half_gap_m(mid, hy, tcp) < object_radius:
            lo = mid
        else:
            hi = mid
    return hi / per_mm


class JawModel:
    """Rod opening (``positions``, (1,) m), motor current (``currents``, (1,) A), motion."""

    preshape_names: tuple[str, ...] = JAW_PRESHAPES

    def __init__(self, params: dict, object_radius: float):
        self.speed = float(params["jaw.speed_mm_s"]) * 1e-3
        self.max_opening = float(params["jaw.max_opening_mm"]) * 1e-3
        self.idle_current = float(params["gripper.idle_current_a"])
        self.moving_current = float(params["gripper.moving_current_a"])
        self.rise_time = float(params["gripper.current_rise_time_s"])
        self.preshape_m = {n: min(self.max_opening, v * 1e-3) for n, v in zip(JAW_PRESHAPES, params["jaw.preshape_mm"])}
        self.contact_at = contact_opening_mm(params, object_radius) * 1e-3
        self.positions = np.zeros(1)  # the jaw starts closed, as an arm is stowed
        self.targets = np.zeros(1)
        self.current = np.full(1, self.idle_current)
        self.motion = GripperMotion.IDLE
        self.current_limit = 0.0
        self.in_contact = False
        self.fault: str | None = None
        self._settled = False

    # ---------------------------------------------------------------- commands

    def preshape(self, shape: str) -> None:
        self._settled = False
        self.in_contact = False
        self.targets[0] = self.preshape_m[shape]
        self.motion = GripperMotion.PRESHAPING

    def close(self, current_limit: float) -> None:
        self._settled = False
        self.current_limit = float(current_limit)
        self.targets[0] = 0.0
        self.motion = GripperMotion.CLOSING

    def open(self) -> None:
        self._settled = False
        self.in_contact = False
        self.targets[0] = self.max_opening
        self.motion = GripperMotion.OPENING

    def stop(self) -> None:
        self._settled = False
        self.targets[:] = self.positions
        if self.motion is not GripperMotion.HOLDING:
            self.motion = GripperMotion.STOPPED

    def lose_contact(self) -> None:
        """The object slipped out: the jaw goes on closing on nothing."""
        self._settled = False
        self.in_contact = False
        if self.motion in (GripperMotion.CLOSING, GripperMotion.HOLDING):
            self.motion = GripperMotion.CLOSING
            self.targets[0] = 0.0

    # ---------------------------------------------------------------- physics

    @property
    def settled(self) -> bool:
        """Nothing changes until the next command."""
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
        pos, target = float(self.positions[0]), float(self.targets[0])
        err = target - pos
        moving = False
        if err != 0.0:
            new = pos + math.copysign(min(abs(err), self.speed * h), err)
            closing_on = self.motion is GripperMotion.CLOSING and contact_possible and self.contact_at > 0.0
            if closing_on and new - 1e-12 <= self.contact_at <= pos:
                new = self.contact_at
                self.targets[0] = new
                touched = not self.in_contact
                self.in_contact = True
            self.positions[0] = new
            moving = new != self.targets[0]
        a = 1.0 - math.exp(-h / self.rise_time)
        if self.in_contact and self.motion in (GripperMotion.CLOSING, GripperMotion.HOLDING):
            self.current[0] += (self.current_limit - self.current[0]) * a
            if self.current[0] >= 0.98 * self.current_limit:
                self.motion = GripperMotion.HOLDING
        else:
            target_current = self.moving_current if moving else self.idle_current
            self.current[0] += (target_current - self.current[0]) * a
            if not moving and self.motion in (GripperMotion.CLOSING, GripperMotion.OPENING, GripperMotion.PRESHAPING):
                self.motion = GripperMotion.STOPPED if self.motion is GripperMotion.CLOSING else GripperMotion.IDLE
            if not moving and abs(self.current[0] - self.idle_current) < 1e-6:
                self.current[0] = self.idle_current
                self._settled = True
        return touched
