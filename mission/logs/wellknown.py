"""Foxglove well-known channels of a run log (protobuf, schemas from ``foxglove-sdk``).

Beside the ``maris.*`` JSON channels (:mod:`mission.logs.channels`), a run log
carries what Foxglove's panels understand natively:

==================  ======================  ====================================================
topic               schema                  content
==================  ======================  ====================================================
``/tf``             foxglove.FrameTransforms ``map -> world -> base_link -> every URDF link``, and
                                            the frames ``vehicle_goal``, ``tool_goal``, every
                                            pose on the blackboard (e.g. ``grasp_pose``, the
                                            grasp frame from vision), ``detection`` (latest
                                            detection, in ``base_link``), ``pipe`` (sim truth)
``/scene/robot``    foxglove.SceneUpdate     the vehicle hull and the arm links, locked to their
                                            frames (so they move with ``/tf``)
``/scene/world``    foxglove.SceneUpdate     pool, pipe, waypoints and their path, geofence
``/log``            foxglove.Log             every ``/events`` entry (the Log panel)
``/waypoints``      foxglove.PosesInFrame    the mission's survey waypoints (``world``)
``/goal/vehicle``   foxglove.PoseInFrame     the KCL vehicle goal (``world``)
``/goal/tool``      foxglove.PoseInFrame     the KCL tool goal, the grasp frame (``world``)
``/arm/joints``     foxglove.JointStates     named joint positions, velocities, efforts (currents)
``/camera/left/     foxglove.CompressedImage the left camera, downscaled JPEG (vision only)
compressed``
``/vision/          foxglove.ImageAnnotations the detection drawn on that image (vision only)
annotations``
==================  ======================  ====================================================

Every message of a topic is complete on its own (the whole frame tree, the
whole scene), so a viewer that seeks, or joins a live run late, needs only
the last one. Builders here are pure: numbers in, SDK message objects out;
:meth:`mission.logs.writer.RunLogWriter.write_message` encodes them. ``/tf`` and
``/arm/joints``, written every 3D-view sample, are encoded without SDK objects
(:mod:`mission.logs.protowire`).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Iterable, Sequence
from typing import Protocol

import numpy as np
from foxglove import Schema
from foxglove import messages as fm

from kcl.rotations import rpy_to_quaternion
from mission.logs.frames import Transform, pose_to_transform


#: topic -> SDK message class (its ``get_schema()`` gives the schema written to the log)
class WellKnownMessage(Protocol):
    """A Foxglove SDK message class: its protobuf schema (the encoding of its instances)."""

    @staticmethod
    def get_schema() -> Schema: ...


WELL_KNOWN: dict[str, type[WellKnownMessage]] = {
    "/tf": fm.FrameTransforms,
    "/scene/robot": fm.SceneUpdate,
    "/scene/world": fm.SceneUpdate,
    "/log": fm.Log,
    "/waypoints": fm.PosesInFrame,
    "/goal/vehicle": fm.PoseInFrame,
    "/goal/tool": fm.PoseInFrame,
    "/arm/joints": fm.JointStates,
    # the vision system's camera frames and their drawings (mission/logs/vision_channels.py),
    # written only when the detector has images (rendered vision, the stereo driver)
    "/camera/left/compressed": fm.CompressedImage,
    "/vision/annotations": fm.ImageAnnotations,
}

#: event level (``/events``) -> foxglove.Log level
LOG_LEVELS = {
    "debug": fm.LogLevel.Debug,
    "info": fm.LogLevel.Info,
    "warning": fm.LogLevel.Warning,
    "fault": fm.LogLevel.Error,
    "fatal": fm.LogLevel.Fatal,
}


def timestamp(ns: int) -> fm.Timestamp:
    return fm.Timestamp(sec=ns // 1_000_000_000, nsec=ns % 1_000_000_000)


def _v3(p: Sequence[float]) -> fm.Vector3:
    return fm.Vector3(x=float(p[0]), y=float(p[1]), z=float(p[2]))


def _quat(q: Sequence[float]) -> fm.Quaternion:
    return fm.Quaternion(x=float(q[0]), y=float(q[1]), z=float(q[2]), w=float(q[3]))


def _pose(position: Sequence[float], quat: Sequence[float] = (0.0, 0.0, 0.0, 1.0)) -> fm.Pose:
    return fm.Pose(position=_v3(position), orientation=_quat(quat))


def _color(r: float, g: float, b: float, a: float = 1.0) -> fm.Color:
    return fm.Color(r=r, g=g, b=b, a=a)


def log_entry(ns: int, level: str, kind: str, message: str) -> fm.Log:
    """An ``/events`` entry as ``foxglove.Log`` (name = the event kind)."""
    return fm.Log(
        timestamp=timestamp(ns),
        level=LOG_LEVELS.get(level, fm.LogLevel.Unknown),
        message=message,
        name=kind,
        file="",
        line=0,
    )


def poses_in_frame(ns: int, frame: str, poses: Iterable[np.ndarray]) -> fm.PosesInFrame:
    out = []
    for T in poses:
        tr = pose_to_transform(frame, "", T)
        out.append(_pose(tr.translation, tr.rotation))
    return fm.PosesInFrame(timestamp=timestamp(ns), frame_id=frame, poses=out)


# ---------------------------------------------------------------- scenes
_HULL = _color(1.0, 0.78, 0.1, 0.55)
_ARM = _color(0.55, 0.57, 0.6, 1.0)
_JOINT = _color(0.25, 0.27, 0.3, 1.0)
_TOOL = _color(0.95, 0.35, 0.1, 1.0)


def _segment_cylinder(
    start: np.ndarray, end: np.ndarray, radius: float, color: fm.Color
) -> fm.CylinderPrimitive | None:
    """A cylinder from ``start`` to ``end`` (m, one frame); None when they coincide."""
    d = np.asarray(end, dtype=float) - np.asarray(start, dtype=float)
    length = float(np.linalg.norm(d))
    if length < 1e-6:
        return None
    z = d / length
    axis = np.cross([0.0, 0.0, 1.0], z)
    s, c = float(np.linalg.norm(axis)), float(z[2])
    if s < 1e-9:
        quat = (0.0, 0.0, 0.0, 1.0) if c > 0 else (1.0, 0.0, 0.0, 0.0)
    else:
        angle = math.atan2(s, c)
        k = axis / s * math.sin(angle / 2)
        quat = (k[0], k[1], k[2], math.cos(angle / 2))
    mid = 0.5 * (np.asarray(start, dtype=float) + np.asarray(end, dtype=float))
    return fm.CylinderPrimitive(
        pose=_pose(mid, quat),
        size=fm.Vector3(x=2 * radius, y=2 * radius, z=length),
        bottom_scale=1.0,
        top_scale=1.0,
        color=color,
    )


def robot_scene(
    ns: int, root: str, edges: Sequence[Transform], visuals: Sequence[dict], tool_link: str | None = None
) -> fm.SceneUpdate:
    """The UVMS drawn from its URDF: ``visuals`` (URDF ``<visual>`` boxes, cylinders,
    spheres, per link; the ``root`` link's, the hull, see-through) and, for every link edge with an offset, a rod from the
    parent link's origin to the child's (in the parent frame), a ball at each
    child origin. ``edges``: the parent -> child transforms at any configuration
    (only the fixed joint offsets are used). Entities are frame-locked: they
    follow ``/tf``."""
    ts = timestamp(ns)
    entities: dict[str, dict] = {}

    def entity(frame: str) -> dict:
        return entities.setdefault(frame, {"cubes": [], "cylinders": [], "spheres": []})

    for v in visuals:
        e = entity(v["link"])
        color = _HULL if v["link"] == root else _ARM
        if v["shape"] == "box":
            e["cubes"].append(fm.CubePrimitive(pose=_pose(v["xyz"], v["quat"]), size=_v3(v["size"]), color=color))
        elif v["shape"] == "cylinder":
            e["cylinders"].append(
                fm.CylinderPrimitive(
                    pose=_pose(v["xyz"], v["quat"]),
                    size=fm.Vector3(x=2 * v["radius"], y=2 * v["radius"], z=v["length"]),
                    bottom_scale=1.0,
                    top_scale=1.0,
                    color=color,
                )
            )
        elif v["shape"] == "sphere":
            r = v["radius"]
            e["spheres"].append(
                fm.SpherePrimitive(
                    pose=_pose(v["xyz"], v["quat"]), size=fm.Vector3(x=2 * r, y=2 * r, z=2 * r), color=color
                )
            )
    for tr in edges:
        rod = _segment_cylinder(np.zeros(3), np.array(tr.translation), 0.035, _ARM)
        if rod is not None:
            entity(tr.parent)["cylinders"].append(rod)
        color = _TOOL if tr.child == tool_link else _JOINT
        size = 0.06 if tr.child == tool_link else 0.08
        entity(tr.child)["spheres"].append(
            fm.SpherePrimitive(pose=_pose((0, 0, 0)), size=fm.Vector3(x=size, y=size, z=size), color=color)
        )
    return fm.SceneUpdate(
        entities=[
            fm.SceneEntity(
                timestamp=ts,
                frame_id=frame,
                id=f"robot/{frame}",
                frame_locked=True,
                lifetime=fm.Duration(sec=0, nsec=0),
                cubes=e["cubes"],
                cylinders=e["cylinders"],
                spheres=e["spheres"],
            )
            for frame, e in entities.items()
        ]
    )


def _box_edges(lo: Sequence[float], hi: Sequence[float]) -> list[fm.Point3]:
    """The 12 edges of an axis-aligned box as a LINE_LIST (24 points)."""
    xs, ys, zs = (lo[0], hi[0]), (lo[1], hi[1]), (lo[2], hi[2])
    corners = [(x, y, z) for x in xs for y in ys for z in zs]
    pts = []
    for i, a in enumerate(corners):
        for b in corners[i + 1 :]:
            if sum(1 for k in range(3) if a[k] != b[k]) == 1:
                pts += [
                    fm.Point3(x=float(a[0]), y=float(a[1]), z=float(a[2])),
                    fm.Point3(x=float(b[0]), y=float(b[1]), z=float(b[2])),
                ]
    return pts


def world_scene(
    ns: int,
    *,
    pool_size: Sequence[float] | None = None,
    geofence: Sequence[Sequence[float]] | None = None,
    pipe: dict | None = None,
    waypoints: Sequence[Sequence[float]] = (),
) -> fm.SceneUpdate:
    """The surroundings in ``world`` (NED, m): pool (``[north, east, depth]`` from
    the corner at the surface), geofence ``[[n0, n1], [e0, e1], [d0, d1]]``, the
    pipe (``{"pose": 4x4 centre frame, x along the axis, "length", "radius"}``)
    and the waypoints ``[x, y, z]`` joined in order."""
    ts = timestamp(ns)
    zero = fm.Duration(sec=0, nsec=0)
    entities = []
    if pool_size is not None:
        n, e, d = (float(v) for v in pool_size)
        floor = fm.CubePrimitive(
            pose=_pose((n / 2, e / 2, d + 0.01)), size=fm.Vector3(x=n, y=e, z=0.02), color=_color(0.78, 0.74, 0.62, 1.0)
        )
        walls = fm.LinePrimitive(
            type=fm.LinePrimitiveLineType.LineList,
            pose=_pose((0, 0, 0)),
            thickness=0.03,
            scale_invariant=False,
            points=_box_edges((0, 0, 0), (n, e, d)),
            color=_color(0.2, 0.45, 0.8, 1.0),
        )
        entities.append(
            fm.SceneEntity(
                timestamp=ts,
                frame_id="world",
                id="pool",
                lifetime=zero,
                frame_locked=True,
                cubes=[floor],
                lines=[walls],
            )
        )
    if geofence is not None:
        lo = [float(b[0]) for b in geofence]
        hi = [float(b[1]) for b in geofence]
        fence = fm.LinePrimitive(
            type=fm.LinePrimitiveLineType.LineList,
            pose=_pose((0, 0, 0)),
            thickness=0.02,
            scale_invariant=False,
            points=_box_edges(lo, hi),
            color=_color(0.9, 0.2, 0.2, 0.8),
        )
        entities.append(
            fm.SceneEntity(
                timestamp=ts, frame_id="world", id="geofence", lifetime=zero, frame_locked=True, lines=[fence]
            )
        )
    if pipe is not None:
        T = np.asarray(pipe["pose"], dtype=float)
        axis = T[:3, 0] * (0.5 * float(pipe["length"]))
        rod = _segment_cylinder(T[:3, 3] - axis, T[:3, 3] + axis, float(pipe["radius"]), _color(1.0, 0.85, 0.0, 1.0))
        entities.append(
            fm.SceneEntity(
                timestamp=ts,
                frame_id=pipe.get("frame", "world"),
                id="pipe",
                lifetime=zero,
                frame_locked=True,
                cylinders=[rod] if rod is not None else [],
            )
        )
    if len(waypoints):
        pts = [fm.Point3(x=float(w[0]), y=float(w[1]), z=float(w[2])) for w in waypoints]
        path = fm.LinePrimitive(
            type=fm.LinePrimitiveLineType.LineStrip,
            pose=_pose((0, 0, 0)),
            thickness=0.03,
            scale_invariant=False,
            points=pts,
            color=_color(0.1, 0.7, 0.3, 1.0),
        )
        balls = [
            fm.SpherePrimitive(
                pose=_pose(w[:3]), size=fm.Vector3(x=0.2, y=0.2, z=0.2), color=_color(0.1, 0.7, 0.3, 1.0)
            )
            for w in waypoints
        ]
        labels = [
            fm.TextPrimitive(
                pose=_pose((w[0], w[1], w[2] - 0.3)),
                billboard=True,
                font_size=14.0,
                scale_invariant=True,
                color=_color(0.05, 0.4, 0.15, 1.0),
                text=f"WP{i + 1}",
            )
            for i, w in enumerate(waypoints)
        ]
        entities.append(
            fm.SceneEntity(
                timestamp=ts,
                frame_id="world",
                id="waypoints",
                lifetime=zero,
                frame_locked=True,
                lines=[path],
                spheres=balls,
                texts=labels,
            )
        )
    return fm.SceneUpdate(entities=entities)


def urdf_visuals(urdf_text: str) -> list[dict]:
    """The ``<visual>`` boxes, cylinders and spheres of a URDF, per link, with their
    origin (xyz m, quaternion x y z w). Meshes are skipped (drawn as rods instead)."""

    out: list[dict] = []
    root = ET.fromstring(urdf_text)
    for link in root.findall("link"):
        for vis in link.findall("visual"):
            origin = vis.find("origin")
            xyz = [float(v) for v in (origin.get("xyz", "0 0 0") if origin is not None else "0 0 0").split()]
            rpy = [float(v) for v in (origin.get("rpy", "0 0 0") if origin is not None else "0 0 0").split()]
            geom = vis.find("geometry")
            if geom is None:
                continue
            base = {"link": link.get("name"), "xyz": xyz, "quat": rpy_to_quaternion(*rpy)}
            if (box := geom.find("box")) is not None:
                out.append({**base, "shape": "box", "size": [float(v) for v in box.get("size", "0 0 0").split()]})
            elif (cyl := geom.find("cylinder")) is not None:
                out.append(
                    {
                        **base,
                        "shape": "cylinder",
                        "radius": float(cyl.get("radius", 0)),
                        "length": float(cyl.get("length", 0)),
                    }
                )
            elif (sph := geom.find("sphere")) is not None:
                out.append({**base, "shape": "sphere", "radius": float(sph.get("radius", 0))})
    return out
