"""What the supervisor writes to the Foxglove well-known channels of the log.

:class:`VizRecorder` is the 3D side of the run log (:mod:`mission.logs.wellknown`):
at the start the robot drawn from its URDF (``/scene/robot``), the pool,
geofence, pipe and survey waypoints (``/scene/world``, ``/waypoints``) and the
URDF as an attachment; during the run, at ``tf_log_hz`` (10 Hz by default, a
modest rate: the link transforms and two messages written per sample),
the frame tree ``/tf`` (vehicle from navigation, links from the measured
joints, goal, target and detection frames) and the named joints
``/arm/joints``, and ``/goal/*`` when the KCL targets change, all encoded by
:mod:`mission.logs.protowire`; every event on
``/log``. Without a log every method does nothing.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from behaviours.action import resolve_goal
from kcl.rotations import homogeneous, rpy_to_matrix
from mission.logs import wellknown as wk
from mission.logs.frames import LinkTree, Transform, eta_to_transform, level_transform, map_transform, pose_to_transform
from mission.logs.protowire import FrameTransformsEncoder, JointStatesEncoder, pose_in_frame
from mission.logs.writer import RunLogWriter


def mission_waypoints(
    mission: Any, start: tuple[float, float, float, float], bottom_depth: float | None
) -> list[list[float]]:
    """World ``[x, y, z, yaw]`` of the waypoints and vehicle goals of the mission's
    main tree and subtrees, in tree order; ``altitude_m`` goals are placed above a
    bottom at ``bottom_depth`` (m; unknown: they keep the previous depth)."""

    nodes: list[Any] = []
    if mission is None:
        return []
    for root in [mission.tree, *dict(mission.subtrees or {}).values()]:
        if root is not None:
            nodes.extend(n for n in root.walk() if n.kind == "action")
    out: list[list[float]] = []
    previous = start
    for node in nodes:
        targets = dict(node.params).get("targets") or {}
        specs = targets.get("waypoints") or ([targets["vehicle_goal"]] if targets.get("vehicle_goal") else [])
        for spec in specs:
            altitude = None if bottom_depth is None else 0.0
            previous = resolve_goal(spec, previous, bottom_depth, altitude)
            out.append([float(v) for v in previous])
    return out


def _goal_pose(goal: np.ndarray) -> np.ndarray:
    """``[x, y, z, yaw]`` -> 4x4 world pose."""
    return homogeneous(rpy_to_matrix(0.0, 0.0, float(goal[3])), np.asarray(goal[:3], dtype=float))


def _finite(T: Any) -> bool:
    return T is not None and bool(np.all(np.isfinite(np.asarray(T, dtype=float))))


class PoseSeen(NamedTuple):
    """A blackboard pose as last drawn: the array and its bytes then (same object and
    same bytes: the same frame, not drawn again)."""

    pose: np.ndarray
    data: bytes


class VizRecorder:
    """The Foxglove channels of one run (see the module docstring)."""

    def __init__(
        self,
        log: RunLogWriter | None,
        model: Any,
        *,
        mission: Any = None,
        backend: Any = None,
        joint_names: Iterable[str] = (),
    ) -> None:
        self.log = log if (log is not None and model is not None and hasattr(log, "write_encoded")) else None
        self.model = model
        self.mission = mission
        self.backend = backend
        self.joint_names = list(joint_names) or (list(model.joint_names) if model is not None else [])
        self.tree = LinkTree(model) if self.log is not None else None
        self._tf = FrameTransformsEncoder()
        self._joints = JointStatesEncoder(self.joint_names)
        self._targets: Any = None
        self._goal_frames: list[Transform] = []
        self._targets_bb: dict[str, Transform] = {}
        bb = getattr(mission, "blackboard", None) or {}
        self._pose_keys = [k for k, v in dict(bb).items() if getattr(v, "type", None) == "pose"]
        self._detection: Transform | None = None
        self._pipe: Transform | None = None
        self._pipe_key: tuple | None = None  # the pipe pose _pipe was computed from
        self._target_src: dict[str, PoseSeen] = {}  # blackboard pose key -> the pose last seen

    @property
    def active(self) -> bool:
        return self.log is not None

    # ------------------------------------------------------------ start
    def start(self, t: float, nav: Any, js: Any) -> None:
        """Robot and world scenes, waypoints, URDF attachment, the first frame tree."""
        log, tree = self.log, self.tree
        if log is None or tree is None:
            return
        ns = log.log_time_ns(t)
        urdf_path = Path(self.model.urdf_path)
        try:
            urdf = urdf_path.read_text(encoding="utf-8")
        except OSError:
            urdf = ""
        if urdf:
            log.attach(urdf_path.name, "application/xml", urdf.encode(), t)
        edges = tree.transforms(np.asarray(js.position, dtype=float))
        visuals = wk.urdf_visuals(urdf) if urdf else []
        tool = self.model.frames.get("tool")
        log.write_message("/scene/robot", ns, wk.robot_scene(ns, tree.root, edges, visuals, tool))
        pool = getattr(self.backend, "pool_size", None)
        bottom = float(pool[2]) if pool is not None else None
        if bottom is None and nav.altitude is not None and math.isfinite(nav.altitude):
            bottom = float(nav.depth) + float(nav.altitude)
        start = (float(nav.position[0]), float(nav.position[1]), float(nav.position[2]), float(nav.attitude[2]))
        waypoints = mission_waypoints(self.mission, start, bottom)
        fence = None
        safety = getattr(self.mission, "safety", None)
        if safety is not None and getattr(safety, "geofence", None) is not None:
            g = safety.geofence
            fence = [list(g.north_m), list(g.east_m), list(g.down_m)]
        pipe = getattr(self.backend, "pipe", None)
        pipe_spec = None
        if pipe is not None:
            pipe_spec = {"pose": np.eye(4), "length": pipe.length, "radius": pipe.radius, "frame": "pipe"}
            self._pipe = pose_to_transform("world", "pipe", pipe.world_T_centre)
        log.write_message(
            "/scene/world", ns, wk.world_scene(ns, pool_size=pool, geofence=fence, pipe=pipe_spec, waypoints=waypoints)
        )
        log.write_message(
            "/waypoints", ns, wk.poses_in_frame(ns, "world", [_goal_pose(np.array(w)) for w in waypoints])
        )
        self.frames(t, nav, js)

    # ------------------------------------------------------------ per sample
    def frames(
        self,
        t: float,
        nav: Any,
        js: Any,
        controller: Any = None,
        blackboard: Any = None,
        detection: Any = None,
        truth: dict | None = None,
    ) -> None:
        """``/tf`` (the whole tree) and ``/arm/joints`` at backend time ``t``; ``/goal/*``
        when the controller's targets changed."""
        log, tree = self.log, self.tree
        if log is None or tree is None:
            return
        ns = log.log_time_ns(t)
        if controller is not None:
            self._update_goals(log, ns, controller)
        if blackboard is not None:
            self._update_target(blackboard)
        if detection is not None and _finite(detection.pose):
            self._detection = pose_to_transform(tree.root, "detection", detection.pose)
        if truth:
            self._update_pipe(truth)
        eta = np.concatenate([np.asarray(nav.position, dtype=float), np.asarray(nav.attitude, dtype=float)])
        q = np.asarray(js.position, dtype=float)
        transforms = [map_transform()]
        if np.all(np.isfinite(eta)):
            transforms.append(eta_to_transform("world", tree.root, eta))
            transforms.append(level_transform(eta[:3]))
        if np.all(np.isfinite(q)):
            transforms.extend(tree.transforms(q))
        transforms.extend(self._goal_frames)
        transforms.extend(self._targets_bb.values())
        for extra in (self._detection, self._pipe):
            if extra is not None:
                transforms.append(extra)
        log.write_encoded("/tf", ns, self._tf.encode(ns, transforms))
        log.write_encoded("/arm/joints", ns, self._joints.encode(ns, js.position, js.velocity, js.current))

    def _update_goals(self, log: RunLogWriter, ns: int, controller: Any) -> None:
        targets = getattr(controller, "targets", None)
        if targets is None or targets is self._targets:
            return
        self._targets = targets
        frames = []
        vg = getattr(targets, "vehicle_goal", None)
        if _finite(vg):
            frame = pose_to_transform("world", "vehicle_goal", _goal_pose(np.asarray(vg, dtype=float)))
            frames.append(frame)
            log.write_encoded("/goal/vehicle", ns, pose_in_frame(ns, "world", frame))
        tg = getattr(targets, "tool_goal", None)
        if tg is not None and _finite(tg):
            frame = pose_to_transform("world", "tool_goal", tg)
            frames.append(frame)
            log.write_encoded("/goal/tool", ns, pose_in_frame(ns, "world", frame))
        self._goal_frames = frames

    def _update_target(self, blackboard: Any) -> None:
        """A frame per pose-typed blackboard key (named after it), e.g. the grasp frame."""
        get = getattr(blackboard, "get", None)
        if get is None or not self._pose_keys:
            return
        for key in self._pose_keys:
            try:
                T = get(key)
            except Exception:  # noqa: BLE001 - a key the blackboard does not hold
                continue
            if type(T) is np.ndarray:  # the same pose as last time (same object, same values): same frame
                seen = self._target_src.get(key)
                raw = T.tobytes()
                if seen is not None and seen.pose is T and seen.data == raw:
                    continue
                self._target_src[key] = PoseSeen(T, raw)
            if T is not None and np.shape(T) == (4, 4) and _finite(T):
                self._targets_bb[key] = pose_to_transform("world", key, np.asarray(T, dtype=float))

    def _update_pipe(self, truth: dict) -> None:
        pipe = truth.get("pipe")
        if not isinstance(pipe, dict) or pipe.get("centre_position") is None:
            return
        p, rpy = pipe["centre_position"], pipe.get("centre_rpy") or (0.0, 0.0, 0.0)
        key = (np.asarray(p, dtype=float).tobytes(), np.asarray(rpy, dtype=float).tobytes())
        if key == self._pipe_key:  # the pipe has not moved: same frame
            return
        self._pipe_key = key
        self._pipe = pose_to_transform("world", "pipe", homogeneous(rpy_to_matrix(*rpy), np.asarray(p, dtype=float)))

    # ------------------------------------------------------------ events
    def event(self, ev: Any) -> None:
        """One event on ``/log`` (foxglove.Log)."""
        if self.log is not None:
            ns = self.log.log_time_ns(ev.t)
            self.log.write_message("/log", ns, wk.log_entry(ns, ev.level, ev.kind, ev.message))
