"""The simulator as a :class:`hal.interfaces.Backend`.

``SimBackend(scenario, seed)`` builds the world, the vehicle, the arm (kinematics
from :class:`kcl.model.UvmsModel`), the gripper, the sensors and the vision from
one scenario and one seed, and advances them all in lockstep with
:meth:`SimBackend.advance`. Every random stream derives from the seed
(:mod:`sim_backend.rng`), so the same scenario, seed and command sequence give
the same run, bit for bit.

One internal step (``sim.step_s``, default 10 ms): arm joints, vehicle
(``vehicle.model``: ``full`` = DCL, thrusters and 6-DOF rigid body pushed by the
arm, :mod:`sim_backend.full_vehicle`; ``first_order`` = the fast kinematic lag of
:mod:`sim_backend.vehicle_dynamics`), gripper (the tool pose is computed only
while the fingers close), then the sensors that are due (AHRS/depth 100 Hz, DVL
~5 Hz, vision ~10 Hz; the arm kinematics for vision run only at image times).

Faults for tests and campaigns: scenario fields ``dvl.dropouts`` and
``vision.dropouts`` (intervals of simulated time), or :meth:`SimBackend.inject`.
"""

from __future__ import annotations

import bisect
import math
import time
from typing import Any

import numpy as np
import pinocchio as pin

from hal.drivers.pushed_input import PushedInput
from hal.interfaces import Backend, DeviceSet, GripperMotion
from kcl.model import UvmsModel, pose_in_world
from maris_common.yamlsrc import ConfigError, ConfigIssue, Mark

from . import vehicle_kernel as vk
from .arm_sim import ArmJoints
from .devices import SimArm, SimDetector, SimGamepad, SimGripper, SimVehicle, SimWrenchSensor
from .full_vehicle import FullVehicle
from .geometry import inverse_pose, pose_from_eta, rpy_from_rotation
from .grasp import GraspTolerances, grasp_errors, grasp_offsets, hand_reaches_pipe, slip_displacement
from .gripper_sim import GripperModel
from .jaw_sim import JawModel
from .ping_sim import PingAltimeter
from .platform import scenario_file
from .rng import NormalBlock, child_rng
from .scenario import Scenario, sample_values
from .sensor_kernel import N_A
from .sensors import Ahrs, Dvl
from .vehicle_dynamics import VehicleDynamics
from .vision import VisionModel
from .vision_calibration import run_errors
from .vision_rendered import RenderedVision, check_model
from .world import Pipe, clamp_to_pool, pipe_rest_depth, pool_bounds

#: Faults accepted by :meth:`SimBackend.inject`.
FAULTS = ("dvl_dropout", "vision_lost", "joint_fault", "gripper_fault", "ahrs_nan")


class SimClock:
    """Simulated time (s), advanced only by the backend."""

    def __init__(self) -> None:
        self.t = 0.0

    def now(self) -> float:
        return self.t


class SimBackend(Backend):
    """UVMS simulator implementing the HAL ``Backend``.

    ``scenario``: from :func:`sim_backend.load_scenario`; ``seed``: the one seed of
    the run; ``realtime``: pace :meth:`advance` to the wall clock; ``model``: the
    UVMS kinematic model (default: the scenario's ``platform.model``, else
    ``UvmsModel.load()``, the shipped URDF).
    """

    def __init__(self, scenario: Scenario, seed: int, realtime: bool = False, model: UvmsModel | None = None):
        if model is None:  # the rig the scenario names (platform.model), else the shipped URDF
            ref = scenario_file(scenario, "model")
            model = UvmsModel.load(None if ref is None else ref.path)
        self.scenario = scenario
        self.seed = int(seed)
        self.realtime = bool(realtime)
        self.model = model
        self.params: dict[str, Any] = sample_values(scenario, self.seed)
        p = self.params
        self.clock: SimClock = SimClock()
        self.step_s = float(p["sim.step_s"])
        # advance(dt) with this dt is one internal step (NaN: never, when paced or below the resolution)
        self._one_step = self.step_s if self.step_s >= 1e-6 and not self.realtime else math.nan
        self.pool_size = tuple(p["pool.size_m"])
        self.turbidity: str = p["vision.turbidity"]

        radius = float(p["pipe.radius_m"])
        self.pipe = Pipe(
            p["pipe.x_m"],
            p["pipe.y_m"],
            pipe_rest_depth(self.pool_size[2], p["pipe.float_height_m"], radius),
            p["pipe.yaw_rad"],
            float(p["pipe.length_m"]),
            radius,
            p["pipe.grasp_offset_m"],
        )
        eta0 = np.array(
            [
                p["vehicle.start_x_m"],
                p["vehicle.start_y_m"],
                p["vehicle.start_z_m"],
                0.0,
                0.0,
                p["vehicle.start_yaw_rad"],
            ]
        )
        half_height = 0.5 * float(p["vehicle.size_m"][2])  # the hull's bottom stops on the floor
        clamp_to_pool(eta0, self.pool_size, half_height)
        current = np.array(p["current.velocity_mps"])
        self.full_model = p["vehicle.model"] == "full"
        self.vehicle: VehicleDynamics | FullVehicle
        #: The vehicle as the model it is: the full one (None with the first-order model) and
        #: the first-order one (None with the full model).
        self._full: FullVehicle | None = None
        self._lag: VehicleDynamics | None = None
        if self.full_model:
            self.vehicle = self._full = FullVehicle(
                p, self.seed, eta0, current, pool_bounds(self.pool_size, half_height), model.urdf_path
            )
        else:
            self.vehicle = self._lag = VehicleDynamics(p, eta0, current, pool_bounds(self.pool_size, half_height))
        self.arm = ArmJoints(p, model.joint_lower, model.joint_upper, model.joint_velocity_limit, self._start_q())
        self.gripper: GripperModel | JawModel = (
            JawModel(p, radius) if p["gripper.model"] == "jaw" else GripperModel(p, radius)
        )
        #: the AHRS state (sim_backend.sensor_kernel layout) then the DVL's velocity (3,), in one
        #: array: a navigation reading is one ``take`` from it (sim_backend.devices.SimVehicle)
        self.nav_buffer = np.zeros(N_A + 3)
        self.dvl = Dvl(p, child_rng(self.seed, "dvl"), self.nav_buffer[N_A:])
        self.ahrs = Ahrs(p, child_rng(self.seed, "ahrs"), self.nav_buffer[:N_A])
        self.ping = PingAltimeter(p, child_rng(self.seed, "ping"))
        if self._full is not None:
            self._full.bind(self.ahrs, self.dvl, self.arm)
            self._full.load_kernels()
        self._arm_in_vehicle = self._full is not None and self._full.steps_arm
        errors = run_errors(p, self.seed)
        self.vision = (
            VisionModel(p, child_rng(self.seed, "vision"), self.turbidity, errors)
            if check_model(self) == "table"
            else RenderedVision(p, self, errors)
        )
        self._vehicle_noise = (
            NormalBlock(child_rng(self.seed, "vehicle"), 6 * 1024) if self.vehicle.has_disturbance else None
        )
        self._no_noise = np.zeros(6)
        self.arm_noise = NormalBlock(child_rng(self.seed, "arm"))
        self.gripper_noise = NormalBlock(child_rng(self.seed, "gripper"))
        self.ft_noise = NormalBlock(child_rng(self.seed, "ft"))
        self._arm_point_frames = tuple(model.joint_names) + ("tool",)
        self._arm_point_ids = [model.frame_id(f) for f in self._arm_point_frames]
        self._camera_id = model.frame_id("stereo_camera")
        self._tool_id = model.frame_id("tool")
        self._fk_model = model.pin_model
        self._fk_data = model.pin_model.createData()
        # the frames' placements in that data, looked up once (Pinocchio updates them in place)
        self._arm_point_placements = [self._fk_data.oMf[i] for i in self._arm_point_ids]
        self._camera_placement = self._fk_data.oMf[self._camera_id]

        self.grasp = "none"
        self._tool_T_pipe: np.ndarray | None = None
        self.events: list[dict] = []  # what happened (grasp, slip, faults), for logs
        self.arm_below_floor = False
        self._non_finite: set[str] = set()
        self._scheduled: list[tuple[float, int, str, Any]] = []
        self._n_scheduled = 0
        self._wall0: float | None = None
        self._sim0 = 0.0

        self.devices = DeviceSet(
            vehicle=SimVehicle(self),
            arm=SimArm(self),
            gripper=SimGripper(self),
            detector=SimDetector(self),
            wrench_sensor=SimWrenchSensor(self) if p["ft.present"] else None,
            operators={
                "gamepad": SimGamepad(self),
                # fed by the live server (stamps in the time it publishes: simulated) and the key reader
                "foxglove": PushedInput("foxglove", self.clock.now, self.clock.now),
                "keyboard": PushedInput("keyboard", self.clock.now),
            },
        )
        self._sample_sensors(0.0)

    def _start_q(self) -> np.ndarray:
        q = self.params["arm.start_q"]
        n = self.model.n_joints
        if q is None:
            return np.clip(np.zeros(n), self.model.joint_lower, self.model.joint_upper)
        if len(q) != n:
            raise ConfigError(
                [
                    ConfigIssue(
                        Mark(self.scenario.source, 1, 1),
                        ("arm", "start_q"),
                        f"expected {n} joint positions for this arm, got {len(q)}",
                    )
                ]
            )
        return np.array(q, dtype=float)

    # ------------------------------------------------------------------ time

    def advance(self, dt: float) -> None:
        """Simulate ``dt`` seconds in equal internal steps of at most ``sim.step_s``."""
        if dt == self._one_step:  # the usual call: one step of dt (as below, with n = 1)
            self._step(dt)
            return
        if not (dt >= 0.0 and math.isfinite(dt)):
            raise ValueError(f"dt must be a finite non-negative number of seconds, got {dt!r}")
        if dt == 0.0:
            return
        if dt < 1e-6:
            raise ValueError(f"dt={dt!r} s is below the simulator's 1 us resolution (the clock counts in ns)")
        n = max(1, math.ceil(dt / self.step_s - 1e-9))
        h = dt / n
        for _ in range(n):
            self._step(h)
        if self.realtime:
            self._pace()

    def _pace(self) -> None:
        now = time.monotonic()
        if self._wall0 is None:
            self._wall0, self._sim0 = now, self.clock.t
            return
        lag = (self.clock.t - self._sim0) - (now - self._wall0)
        if lag > 0.0:
            time.sleep(lag)

    def _step(self, h: float) -> None:
        t_end = round(self.clock.t + h, 9)  # no float creep in long runs
        if self._scheduled:
            self._apply_due_faults(t_end)
        if not self._arm_in_vehicle:  # (the coupled vehicle's step does the arm's first)
            self.arm.step(h)  # first: the full vehicle feels this step's joint accelerations
        vn = self._vehicle_noise
        full = self._full
        if full is not None:
            # the AHRS sample due at the end of the step: the coupled vehicle step takes it
            # (then _sample_sensors must not: its due check is made once per step)
            sample_t = t_end if t_end + 1e-12 >= self.ahrs.next_t else -1.0
            if vn is None:
                ahrs_taken = full.step_drawn(h, self._no_noise, 0, sample_t)
            else:
                buf, i = vn.reserve(6)
                ahrs_taken = full.step_drawn(h, buf, i, sample_t)
        else:
            ahrs_taken = False
            self.vehicle.step(h, vn.take_list(6) if vn is not None else None)
        g = self.gripper
        if g.motion is not GripperMotion.CLOSING:
            if g.fault is not None or not g.settled:  # a settled gripper's step changes nothing
                g.step(h, False)
        elif g.in_contact or self.grasp == "holding":
            g.step(h, True)  # squeezing (again) a pipe that is in the hand
        elif g.step(h, self._pipe_in_hand()):
            self._on_contact()
        self.clock.t = t_end
        self._sample_sensors(t_end, ahrs_taken)

    def _sample_sensors(self, t: float, ahrs_taken: bool = False) -> None:
        """Take the samples due at time ``t`` (s); ``ahrs_taken``: the vehicle's step took the AHRS's."""
        veh = self.vehicle
        eta = veh.eta
        ahrs, dvl = self.ahrs, self.dvl
        if not ahrs_taken and t + 1e-12 >= ahrs.next_t:  # due (checked here too: saves a call per step between samples)
            full, lag = self._full, self._lag
            if full is not None:
                ahrs.update(t, eta, veh.nu, full.vibration_level, full.nav_xy)
            elif lag is not None:
                ahrs.update(t, eta, veh.nu, lag.activity())
        if dvl.present and t + 1e-12 >= dvl.next_t:
            dvl.update(t, veh.nu, self.pool_size[2] - eta[2])
        if self.ping.present and t + 1e-12 >= self.ping.next_t:
            self.ping.update(t, eta, self.pool_size[2])
        vis = self.vision
        if t + 1e-12 >= vis.next_t:  # vis.due(t), inline
            # the arm's frames at image times: one forward kinematics on the simulator's own
            # Pinocchio data (the same products as UvmsModel.frame_pose_vehicle, frame by frame)
            pm, pd = self._fk_model, self._fk_data
            pin.forwardKinematics(pm, pd, self.arm.q)
            pin.updateFramePlacements(pm, pd)
            wTv = pose_from_eta(eta)
            R, o = wTv[:3, :3], wTv[:3, 3]
            arm_points = np.array([M.translation for M in self._arm_point_placements]).dot(R.T) + o
            vis.capture(t, wTv, wTv.dot(self._camera_placement.homogeneous), self.pipe_grasp_pose(), arm_points)
            self._check_floor(t, float(arm_points[:, 2].max()))
        if vis.pending:  # (saves a call on the steps with nothing to publish)
            vis.publish(t)

    # ------------------------------------------------------------------ grasp

    def _check_floor(self, t: float, deepest_arm_point: float) -> None:
        """Collisions are not simulated; an arm reaching below the floor is only
        flagged (edge-triggered event, and ``arm_below_floor`` in the truth)."""
        below = deepest_arm_point > self.pool_size[2]
        if below != self.arm_below_floor:
            self.arm_below_floor = below
            self.events.append(
                {"t": t, "event": "arm_below_floor" if below else "arm_above_floor", "depth_m": deepest_arm_point}
            )

    def note_command(self, device: str, finite: bool) -> None:
        """Record NaN/inf commands (the device treats them as zero, i.e. stops):
        one ``non_finite_command`` event per episode of bad commands."""
        if finite:
            if self._non_finite:
                self._non_finite.discard(device)
        elif device not in self._non_finite:
            self._non_finite.add(device)
            self.events.append({"t": self.clock.t, "event": "non_finite_command", "device": device})

    def place_vehicle(self, eta: np.ndarray) -> None:
        """Put the simulated vehicle at world pose ``eta`` (x, y, z m NED, roll, pitch,
        yaw rad) at rest: a mixed run whose vehicle is real places it where the real one's
        navigation says (:class:`hal.mixed.MixedBackend` with ``follow_vehicle``), so that
        the simulated sensors see the simulated world from there."""
        veh = self.vehicle
        veh.eta[:] = np.asarray(eta, dtype=float)
        veh.nu[:] = 0.0
        if self._full is not None:  # the DCL's depth observer and dead reckoning start from there
            self._full.s[vk.S_ZHAT] = veh.eta[2]
            self._full.nav_xy[:] = veh.eta[:2]

    def ground_truth_vehicle_pose(self) -> np.ndarray:
        """World pose (4, 4) of the vehicle frame now (truth, not the navigation estimate)."""
        return pose_from_eta(self.vehicle.eta)

    def tool_pose(self) -> np.ndarray:
        """World pose (4, 4) of the tool frame now: as
        :meth:`kcl.model.UvmsModel.frame_pose_world` computes it, on the simulator's own Pinocchio
        data (the controller's kinematics cache is left alone)."""
        pm, pd = self._fk_model, self._fk_data
        pin.forwardKinematics(pm, pd, self.arm.q)
        return pose_in_world(pin.updateFramePlacement(pm, pd, self._tool_id).homogeneous, self.vehicle.eta)

    def pipe_centre_pose(self, tool: np.ndarray | None = None) -> np.ndarray:
        """World pose (4, 4) of the pipe's centre frame (follows the tool while held;
        ``tool``: the tool pose now, if already computed)."""
        if self._tool_T_pipe is not None:
            return (self.tool_pose() if tool is None else tool).dot(self._tool_T_pipe)
        return self.pipe.world_T_centre

    def pipe_grasp_pose(self, tool: np.ndarray | None = None) -> np.ndarray:
        """World pose (4, 4) of the pipe's grasp frame."""
        if self._tool_T_pipe is not None:
            self.pipe.world_T_centre = self.pipe_centre_pose(tool)
        return self.pipe.grasp_pose()

    def _pipe_in_hand(self) -> bool:
        return hand_reaches_pipe(self.tool_pose(), self.pipe, self.params["grasp.capture_radius_m"])

    def grasp_errors(self, tool: np.ndarray | None = None) -> tuple[float, float]:
        """``(position error m, axis error rad)`` of the tool frame w.r.t. the grasp frame."""
        tool = self.tool_pose() if tool is None else tool
        return grasp_errors(tool, self.pipe_grasp_pose(tool))

    def _on_contact(self) -> None:
        p = self.params
        tool = self.tool_pose()
        pos_err, axis_err = self.grasp_errors(tool)
        offsets = grasp_offsets(tool, self.pipe)
        failed = offsets.failed_checks(GraspTolerances.from_params(p), self.pipe.length)
        ok = not failed
        self.events.append(
            {
                "t": self.clock.t,
                "event": "grasp" if ok else "slip",
                "position_error_m": pos_err,
                "axis_error_rad": axis_err,
                **offsets.as_dict(),
                "failed": failed,
            }
        )
        if ok:
            self.grasp = "holding"
            self._tool_T_pipe = inverse_pose(tool) @ self.pipe.world_T_centre
            return
        self.grasp = "slipped"
        self.pipe.world_T_centre[:3, 3] += slip_displacement(tool[:3, 3], self.pipe, p["grasp.capture_radius_m"])
        self.gripper.lose_contact()

    def held_load_in_tool(self) -> tuple[np.ndarray, np.ndarray]:
        """Force (N) and torque (N m) of the held pipe's wet weight on the hand,
        tool frame; zero when nothing is held."""
        if self._tool_T_pipe is None:
            return np.zeros(3), np.zeros(3)
        wTt = self.tool_pose()
        f_world = np.array([0.0, 0.0, float(self.params["pipe.wet_weight_n"])])  # NED: +z is down
        f_tool = wTt[:3, :3].T @ f_world
        return f_tool, np.cross(self._tool_T_pipe[:3, 3], f_tool)

    def release_if_holding(self) -> None:
        """Opening the hand lets go of the pipe; it stays where it is (about neutral buoyancy)."""
        if self.grasp == "holding":
            self.pipe.world_T_centre = self.pipe_centre_pose()
            self._tool_T_pipe = None
            self.grasp = "none"
            self.events.append({"t": self.clock.t, "event": "release"})

    # ------------------------------------------------------------------ faults

    def inject(
        self, fault: str, start: float | None = None, duration: float | None = None, joint: int | str | None = None
    ) -> None:
        """Inject a fault from ``start`` (s, default now) for ``duration`` (s, default: for ever).

        ``dvl_dropout`` (no DVL pings), ``vision_lost`` (no detections),
        ``joint_fault`` (drive ``joint``, index or name, stops and reports a fault;
        not timed), ``gripper_fault`` (the gripper stops and reports a fault),
        ``ahrs_nan`` (AHRS outputs NaN).
        """
        if fault not in FAULTS:
            raise ValueError(f"unknown fault {fault!r}; known: {', '.join(FAULTS)}")
        t0 = self.clock.t if start is None else float(start)
        t1 = math.inf if duration is None else t0 + float(duration)
        if fault == "dvl_dropout":
            self.dvl.dropouts.append((t0, t1))
        elif fault == "vision_lost":
            self.vision.dropouts.append((t0, t1))
        else:
            if fault == "joint_fault":
                if isinstance(joint, str):
                    if joint not in self.model.joint_names:
                        raise ValueError(f"unknown joint {joint!r}; joints: {', '.join(self.model.joint_names)}")
                    joint = self.model.joint_names.index(joint)
                if joint is None or not (0 <= int(joint) < self.arm.n):
                    raise ValueError(f"joint_fault needs a joint index in [0, {self.arm.n}) or a joint name")
            self._n_scheduled += 1
            bisect.insort(self._scheduled, (t0, self._n_scheduled, fault, joint))
            self._apply_due_faults(self.clock.t)
        self.events.append(
            {
                "t": self.clock.t,
                "event": "inject",
                "fault": fault,
                "start": t0,
                "end": None if math.isinf(t1) else t1,
                "joint": joint,
            }
        )

    def _apply_due_faults(self, t: float) -> None:
        """Apply, in order, the scheduled faults starting at or before ``t`` (s)."""
        while self._scheduled and self._scheduled[0][0] <= t:
            _, _, kind, arg = self._scheduled.pop(0)
            self._apply_fault(kind, arg)

    def _apply_fault(self, kind: str, arg: Any) -> None:
        if kind == "joint_fault":
            self.arm.fault(int(arg), "drive fault (injected)")
        elif kind == "gripper_fault":
            self.gripper.fault = "motor group fault (injected)"
            self.gripper.stop()
        elif kind == "ahrs_nan":
            self.ahrs.nan_fault = True

    # ------------------------------------------------------------------ truth

    def truth_brief(self) -> dict:
        """The part of :meth:`ground_truth` a run without a log reads: ``t``,
        ``tool_to_target_m``, ``tool_axis_error_rad``, ``grasp`` and ``events``
        (the same values)."""
        pos_err, axis_err = self.grasp_errors(self.tool_pose())
        return {
            "t": self.clock.t,
            "tool_to_target_m": pos_err,
            "tool_axis_error_rad": axis_err,
            "grasp": self.grasp,
            "events": list(self.events),
        }

    def ground_truth(self) -> dict:
        """JSON-able truth now: vehicle pose/velocity (world, body), pipe poses,
        tool-to-grasp errors, grasp state, what the camera saw."""
        veh = self.vehicle
        tool = self.tool_pose()
        pos_err, axis_err = self.grasp_errors(tool)
        return {
            "t": self.clock.t,
            "scenario": self.scenario.name,
            "seed": self.seed,
            "turbidity": self.turbidity,
            "dvl_present": self.dvl.present,
            "vehicle": {
                "eta": veh.eta.tolist(),
                "body_velocity": veh.nu.tolist(),
                "commanded_velocity": veh.command.tolist(),
            },
            "arm": {"q": self.arm.q.tolist(), "qdot": self.arm.qdot.tolist()},
            "tool": {"position": tool[:3, 3].tolist(), "rpy": list(rpy_from_rotation(tool[:3, :3]))},
            "pipe": self.pipe.pose_dict(),
            "tool_to_target_m": pos_err,
            "tool_axis_error_rad": axis_err,
            "grasp": self.grasp,
            "gripper_motion": self.gripper.motion.value,
            "vision": dict(self.vision.last_view),
            "arm_below_floor": self.arm_below_floor,
            "events": list(self.events),
        }
