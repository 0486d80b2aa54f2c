"""Reading and writing stereo calibration files (see :mod:`vision.calibration`
for the formats and conventions); every problem is a
:class:`maris_common.yamlsrc.ConfigError` naming file, line and field."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import numpy as np

from maris_common.yamlsrc import ConfigError, ConfigIssue, Located, Mark, load_yaml
from vision.calibration import DISTORTION_LENGTHS, CameraModel, StereoCalibration

_ALIASES: dict[str, tuple[str, ...]] = {
    "K1": ("M1", "K1", "cameraMatrix1", "camera_matrix_left", "left_camera_matrix", "K_left", "cameraMatrixL"),
    "D1": ("D1", "dist1", "distCoeffs1", "distortion_left", "left_distortion", "D_left", "distCoeffsL"),
    "K2": ("M2", "K2", "cameraMatrix2", "camera_matrix_right", "right_camera_matrix", "K_right", "cameraMatrixR"),
    "D2": ("D2", "dist2", "distCoeffs2", "distortion_right", "right_distortion", "D_right", "distCoeffsR"),
    "R": ("R", "R_stereo", "rotation"),
    "T": ("T", "T_stereo", "translation"),
}


# --------------------------------------------------------------------------- checks


class _Issues:
    """Collects problems of one file; marks come from the YAML tree or from the text."""

    def __init__(self, path: str, text: str = "", located: Located | None = None):
        self.path = path
        self.text = text
        self.located = located
        self.issues: list[ConfigIssue] = []

    def mark(self, key: tuple) -> Mark:
        if self.located is not None:
            return self.located.mark(key)
        if key and self.text:
            m = re.search(rf'^\s*"?{re.escape(str(key[0]))}"?\s*:', self.text, re.MULTILINE)
            if m:
                line = self.text.count("\n", 0, m.start()) + 1
                return Mark(self.path, line, m.start() - self.text.rfind("\n", 0, m.start()))
        return Mark(self.path, 1, 1)

    def add(self, key: tuple, message: str) -> None:
        self.issues.append(ConfigIssue(self.mark(key), key, message))

    def raise_if_any(self) -> None:
        if self.issues:
            raise ConfigError(self.issues)


def _matrix(
    raw: Any, shape: tuple[int, int] | None, key: tuple, issues: _Issues, *, vector: bool = False
) -> np.ndarray | None:
    try:
        arr = np.asarray(raw, dtype=float)
    except (TypeError, ValueError):
        issues.add(key, f"expected numbers, got {raw!r}")
        return None
    if vector:
        arr = arr.reshape(-1)
        if arr.size not in DISTORTION_LENGTHS:
            issues.add(
                key, f"expected {', '.join(map(str, DISTORTION_LENGTHS[1:]))} distortion coefficients, got {arr.size}"
            )
            return None
    elif shape is not None:
        if arr.size == shape[0] * shape[1] and (arr.ndim == 1 or 1 in arr.shape) and shape[1] == 1:
            arr = arr.reshape(shape)
        if arr.shape != shape:
            got = "x".join(map(str, arr.shape)) or "a scalar"
            issues.add(key, f"expected a {shape[0]}x{shape[1]} matrix, got {got}")
            return None
    if not np.all(np.isfinite(arr)):
        issues.add(key, "contains non-finite values")
        return None
    return arr


def _check_camera(K: np.ndarray | None, width: int | None, height: int | None, key: tuple, issues: _Issues) -> None:
    if K is None or width is None or height is None:
        return
    if not (K[0, 0] > 0 and K[1, 1] > 0):
        issues.add(key, f"focal lengths must be positive, got fx={K[0, 0]:g}, fy={K[1, 1]:g}")
    if not (0 <= K[0, 2] < width and 0 <= K[1, 2] < height):
        issues.add(key, f"principal point ({K[0, 2]:g}, {K[1, 2]:g}) lies outside the {width}x{height} image")
    if abs(K[2, 2] - 1.0) > 1e-6 or abs(K[1, 0]) > 1e-9 or abs(K[2, 0]) > 1e-9 or abs(K[2, 1]) > 1e-9:
        issues.add(key, "not a camera matrix: expected [[fx, s, cx], [0, fy, cy], [0, 0, 1]]")


def _check_rotation(R: np.ndarray | None, key: tuple, issues: _Issues) -> None:
    if R is not None and (np.abs(R @ R.T - np.eye(3)).max() > 1e-3 or np.linalg.det(R) < 0):
        issues.add(key, "not a rotation matrix (R R^T must be I and det(R) = 1)")


def _size(w: Any, h: Any, key: tuple, issues: _Issues) -> tuple[int | None, int | None]:
    ok = all(
        isinstance(v, (int, float)) and not isinstance(v, bool) and float(v).is_integer() and v > 0 for v in (w, h)
    )
    if not ok:
        issues.add(key, f"image size must be two positive integers, got {w!r} x {h!r}")
        return None, None
    return int(w), int(h)


# --------------------------------------------------------------------------- OpenCV FileStorage


def _is_filestorage(text: str) -> bool:
    head = text.lstrip()[:200]
    return (
        head.startswith("%YAML") or "!!opencv-matrix" in text or '"opencv-matrix"' in text or head.startswith("<?xml")
    )


def _read_filestorage(path: Path) -> tuple[dict[str, Any], list[tuple[str, str]]]:
    """Top-level entries of a FileStorage file as numpy arrays / numbers / strings,
    and ``(key, problem)`` for entries OpenCV cannot read."""
    import cv2

    try:
        fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    except (cv2.error, SystemError) as exc:  # OpenCV's parser raises either on a malformed file
        msg = str(exc).strip().splitlines()[-1] if str(exc).strip() else "parse error"
        raise ConfigError(
            [ConfigIssue(Mark(str(path), 1, 1), (), f"not a readable OpenCV FileStorage file: {msg}")]
        ) from None
    try:
        if not fs.isOpened():
            raise ConfigError([ConfigIssue(Mark(str(path), 1, 1), (), "not a readable OpenCV FileStorage file")])
        out: dict[str, Any] = {}
        problems: list[tuple[str, str]] = []
        root = fs.root()
        for key in root.keys():
            node = fs.getNode(key)
            if node.isMap() or node.isSeq():
                try:
                    mat = node.mat()
                except (cv2.error, SystemError):
                    r, c, n = node.getNode("rows").real(), node.getNode("cols").real(), node.getNode("data").size()
                    problems.append(
                        (key, f"rows x cols = {int(r)}x{int(c)} needs {int(r * c)} numbers, `data` has {n}")
                    )
                    continue
                if mat is not None:
                    out[key] = np.asarray(mat, dtype=float)
                elif node.isSeq():
                    out[key] = [node.at(i).real() for i in range(node.size())]
            elif node.isString():
                out[key] = node.string()
            elif node.isInt() or node.isReal():
                out[key] = node.real()
        return out, problems
    finally:
        fs.release()


def _pick(entries: dict[str, Any], role: str) -> tuple[str | None, Any]:
    for name in _ALIASES[role]:
        if name in entries:
            return name, entries[name]
    return None, None


def _filestorage_size(entries: dict[str, Any], issues: _Issues) -> tuple[int | None, int | None]:
    if "image_width" in entries or "image_height" in entries:
        return _size(entries.get("image_width"), entries.get("image_height"), ("image_width",), issues)
    for key in ("imageSize", "image_size"):
        if key in entries:
            v = np.asarray(entries[key], dtype=float).reshape(-1)
            if v.size != 2:
                issues.add((key,), f"expected [width, height], got {v.size} values")
                return None, None
            return _size(v[0], v[1], (key,), issues)
    if "width" in entries or "height" in entries:
        return _size(entries.get("width"), entries.get("height"), ("width",), issues)
    issues.add((), "missing the image size: write image_width and image_height (pixels)")
    return None, None


def _from_filestorage(paths: list[Path]) -> StereoCalibration:
    entries: dict[str, Any] = {}
    text = ""
    problems: list[tuple[str, str]] = []
    for p in paths:
        e, pr = _read_filestorage(p)
        entries.update(e)
        problems += pr
        text += p.read_text(encoding="utf-8", errors="replace")
    where = " + ".join(str(p) for p in paths)
    issues = _Issues(where, text)
    for key, msg in problems:
        issues.add((key,), msg)
        entries.pop(key, None)
    if problems:
        issues.raise_if_any()
    w, h = _filestorage_size(entries, issues)
    vals: dict[str, np.ndarray | None] = {}
    for role, shape in (("K1", (3, 3)), ("K2", (3, 3)), ("R", (3, 3)), ("T", (3, 1))):
        name, raw = _pick(entries, role)
        if name is None:
            issues.add((), f"missing `{_ALIASES[role][0]}` (also accepted: {', '.join(_ALIASES[role][1:4])})")
            vals[role] = None
            continue
        if role == "R" and np.asarray(raw).size == 3:  # a Rodrigues vector
            import cv2

            raw = cv2.Rodrigues(np.asarray(raw, dtype=float).reshape(3, 1))[0]
        vals[role] = _matrix(raw, shape, (name,), issues)
    for role in ("D1", "D2"):
        name, raw = _pick(entries, role)
        vals[role] = np.zeros(5) if name is None else _matrix(raw, None, (name,), issues, vector=True)
    _check_camera(vals["K1"], w, h, (_pick(entries, "K1")[0] or "M1",), issues)
    _check_camera(vals["K2"], w, h, (_pick(entries, "K2")[0] or "M2",), issues)
    _check_rotation(vals["R"], (_pick(entries, "R")[0] or "R",), issues)
    if vals["T"] is not None and np.linalg.norm(vals["T"]) < 1e-6:
        issues.add((_pick(entries, "T")[0] or "T",), "zero baseline: the two cameras are at the same place")
    issues.raise_if_any()
    assert w is not None and h is not None
    return StereoCalibration(
        CameraModel(w, h, vals["K1"], vals["D1"], "left"),
        CameraModel(w, h, vals["K2"], vals["D2"], "right"),  # type: ignore[arg-type]
        vals["R"],
        vals["T"].reshape(3),
        where,
    )  # type: ignore[union-attr]


# --------------------------------------------------------------------------- ROS camera_info


_ROS_KEYS = (
    "image_width",
    "image_height",
    "camera_matrix",
    "distortion_coefficients",
    "rectification_matrix",
    "projection_matrix",
)


def _is_ros(data: Any) -> bool:
    return isinstance(data, dict) and "camera_matrix" in data and isinstance(data["camera_matrix"], dict)


def _ros_matrix(src: Located, key: str, shape: tuple[int, int] | None, issues: _Issues) -> np.ndarray | None:
    node = src.data.get(key)
    if not isinstance(node, dict) or "data" not in node:
        issues.add((key,), "expected a mapping with rows, cols and data")
        return None
    data = node["data"]
    if not isinstance(data, list):
        issues.add((key, "data"), f"expected a list of numbers, got {data!r}")
        return None
    rows, cols = node.get("rows"), node.get("cols")
    if shape is not None and (rows, cols) != shape:
        issues.add((key,), f"expected rows: {shape[0]}, cols: {shape[1]}, got rows: {rows}, cols: {cols}")
        return None
    if isinstance(rows, int) and isinstance(cols, int) and len(data) != rows * cols:
        issues.add((key, "data"), f"rows x cols = {rows}x{cols} needs {rows * cols} numbers, got {len(data)}")
        return None
    if shape is None:
        return _matrix(data, None, (key, "data"), issues, vector=True)
    return _matrix(
        np.asarray(data, dtype=object).reshape(shape) if len(data) == shape[0] * shape[1] else data,
        shape,
        (key, "data"),
        issues,
    )


def _read_ros(src: Located) -> tuple[CameraModel | None, np.ndarray | None, np.ndarray | None, _Issues]:
    issues = _Issues(src.file, located=src)
    data = src.data
    missing = [k for k in _ROS_KEYS if k not in data]
    for k in missing:
        issues.add((), f"missing `{k}` (ROS camera_info YAML)")
    if missing:
        return None, None, None, issues
    w, h = _size(data["image_width"], data["image_height"], ("image_width",), issues)
    K = _ros_matrix(src, "camera_matrix", (3, 3), issues)
    D = _ros_matrix(src, "distortion_coefficients", None, issues)
    Rr = _ros_matrix(src, "rectification_matrix", (3, 3), issues)
    P = _ros_matrix(src, "projection_matrix", (3, 4), issues)
    model = data.get("distortion_model", "plumb_bob")
    if model not in ("plumb_bob", "rational_polynomial", "equidistant", None):
        issues.add(("distortion_model",), f"unsupported distortion model `{model}` (plumb_bob or rational_polynomial)")
    elif model == "equidistant":
        issues.add(("distortion_model",), "fisheye (equidistant) calibrations are not supported by the pipe detector")
    _check_camera(K, w, h, ("camera_matrix",), issues)
    _check_rotation(Rr, ("rectification_matrix",), issues)
    if P is not None and not P[0, 0] > 0:
        issues.add(("projection_matrix",), "P[0][0] (rectified fx) must be positive")
    cam = (
        None
        if (K is None or D is None or w is None or h is None)
        else CameraModel(w, h, K, D, str(data.get("camera_name") or ""))
    )
    return cam, Rr, P, issues


def _from_ros(left: Located, right: Located) -> StereoCalibration:
    cl, R1, P1, il = _read_ros(left)
    cr, R2, P2, ir = _read_ros(right)
    issues = il.issues + ir.issues
    if not issues and P2 is not None and abs(P2[0, 3]) < 1e-9:
        issues.append(
            ConfigIssue(
                right.mark(("projection_matrix",)),
                ("projection_matrix",),
                "P[0][3] is 0: this is not the right camera of a stereo pair (P[0][3] = -fx' * baseline)",
            )
        )
    if issues:
        raise ConfigError(issues)
    assert cl and cr and R1 is not None and R2 is not None and P1 is not None and P2 is not None
    # rectified frames: X_rect_l = R1 X_l, X_rect_r = R2 X_r, and X_rect_r = X_rect_l + t with t = [P2[0,3] / fx', 0, 0]
    t = np.array([P2[0, 3] / P2[0, 0], P2[1, 3] / P2[1, 1] if P2[1, 1] else 0.0, 0.0])
    R = R2.T @ R1
    T = R2.T @ t
    return StereoCalibration(cl, cr, R, T, f"{left.file} + {right.file}")


# --------------------------------------------------------------------------- entry points


def load_stereo_calibration(path: str | Path, right_path: str | Path | None = None) -> StereoCalibration:
    """Read a stereo calibration (see the module docstring for the formats).

    ``path`` alone: an OpenCV FileStorage file with both cameras. With
    ``right_path``: two ROS ``camera_info`` files (left, right), or OpenCV's
    intrinsics + extrinsics files. Raises :class:`ConfigError`.
    """
    paths = [Path(path)] + ([Path(right_path)] if right_path is not None else [])
    for p in paths:
        if not p.is_file():
            raise ConfigError([ConfigIssue(Mark(str(p), 1, 1), (), "calibration file not found")])
    texts = [p.read_text(encoding="utf-8", errors="replace") for p in paths]
    if all(_is_filestorage(t) or (p.suffix == ".json" and _json_is_filestorage(t)) for p, t in zip(paths, texts)):
        return _from_filestorage(paths)
    docs = [load_yaml(p) for p in paths]
    if all(_is_ros(d.data) for d in docs):
        if len(docs) != 2:
            raise ConfigError(
                [
                    ConfigIssue(
                        Mark(str(paths[0]), 1, 1),
                        (),
                        "a ROS camera_info file holds one camera: give the right camera's file too",
                    )
                ]
            )
        return _from_ros(docs[0], docs[1])
    if all(isinstance(d.data, dict) for d in docs) and any(k in d.data for d in docs for k in ("M1", "K1", "R", "T")):
        # plain YAML with lists instead of !!opencv-matrix nodes (hand-written)
        entries: dict[str, Any] = {}
        for d in docs:
            entries.update(d.data)
        return _from_plain(entries, docs)
    raise ConfigError(
        [
            ConfigIssue(
                Mark(str(paths[0]), 1, 1),
                (),
                "not a stereo calibration: expected an OpenCV FileStorage file (M1, D1, M2, D2, R, T) "
                "or two ROS camera_info files",
            )
        ]
    )


def _json_is_filestorage(text: str) -> bool:
    try:
        data = json.loads(text)
    except ValueError:
        return False
    return isinstance(data, dict) and any(
        isinstance(v, dict) and v.get("type_id") == "opencv-matrix" for v in data.values()
    )


def _from_plain(entries: dict[str, Any], docs: list[Located]) -> StereoCalibration:
    """Hand-written YAML: the FileStorage key names with nested lists as matrices."""
    src = (
        docs[0]
        if len(docs) == 1
        else Located(entries, " + ".join(d.file for d in docs), {k: v for d in docs for k, v in d.marks.items()})
    )
    issues = _Issues(src.file, located=src)
    converted = {
        k: (np.asarray(v, dtype=float) if isinstance(v, list) and _numeric(v) else v) for k, v in entries.items()
    }
    bad = [k for k, v in entries.items() if isinstance(v, list) and not _numeric(v)]
    for k in bad:
        issues.add((k,), "expected a list of numbers or a list of rows")
    issues.raise_if_any()
    tmp_issues = _Issues(src.file, located=src)
    w, h = _filestorage_size(converted, tmp_issues)
    tmp_issues.raise_if_any()
    vals: dict[str, Any] = {}
    for role, shape in (("K1", (3, 3)), ("K2", (3, 3)), ("R", (3, 3)), ("T", (3, 1))):
        name, raw = _pick(converted, role)
        if name is None:
            issues.add((), f"missing `{_ALIASES[role][0]}`")
            continue
        vals[role] = _matrix(raw, shape, (name,), issues)
    for role in ("D1", "D2"):
        name, raw = _pick(converted, role)
        vals[role] = np.zeros(5) if name is None else _matrix(raw, None, (name,), issues, vector=True)
    _check_camera(vals.get("K1"), w, h, ("M1",), issues)
    _check_camera(vals.get("K2"), w, h, ("M2",), issues)
    _check_rotation(vals.get("R"), ("R",), issues)
    issues.raise_if_any()
    return StereoCalibration(
        CameraModel(w, h, vals["K1"], vals["D1"], "left"),
        CameraModel(w, h, vals["K2"], vals["D2"], "right"),  # type: ignore[arg-type]
        vals["R"],
        vals["T"].reshape(3),
        src.file,
    )


def _numeric(v: Any) -> bool:
    flat = v if not v or not isinstance(v[0], list) else [x for row in v if isinstance(row, list) for x in row]
    return all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in flat) and (
        not v or not isinstance(v[0], list) or all(isinstance(r, list) for r in v)
    )


def save_stereo_calibration(calib: StereoCalibration, path: str | Path) -> Path:
    """Write an OpenCV FileStorage file (YAML, or JSON for a ``.json`` path) with
    ``M1 D1 M2 D2 R T image_width image_height``, readable by OpenCV and by
    :func:`load_stereo_calibration`."""
    import cv2

    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    fs = cv2.FileStorage(str(p), cv2.FILE_STORAGE_WRITE)
    try:
        fs.write("image_width", int(calib.left.width))
        fs.write("image_height", int(calib.left.height))
        fs.write("M1", np.asarray(calib.left.K, dtype=float))
        fs.write("D1", np.asarray(calib.left.D, dtype=float).reshape(1, -1))
        fs.write("M2", np.asarray(calib.right.K, dtype=float))
        fs.write("D2", np.asarray(calib.right.D, dtype=float).reshape(1, -1))
        fs.write("R", np.asarray(calib.R, dtype=float))
        fs.write("T", np.asarray(calib.T, dtype=float).reshape(3, 1))
    finally:
        fs.release()
    return p
