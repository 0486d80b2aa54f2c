"""Reading and writing stereo calibration files (see :mod:`vision.calibration`
for the formats and conventions); every problem is a
:class:`maris_common.yamlsrc.ConfigError` naming file, line and field.

A missing distortion is never taken as zero: a camera without distortion
coefficients is an error naming the keys looked for, unless the file says
``distortion: none`` (or the camera's distortion key holds ``none``; Kalibr's
``distortion_model: none``).
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import numpy as np

from maris_common.yamlsrc import ConfigError, ConfigIssue, Located, Mark, load_yaml
from vision.calibration import DISTORTION_LENGTHS, CameraModel, StereoCalibration

#: Key names of one stereo file (OpenCV's samples and the tools people use), per role.
_ALIASES: dict[str, tuple[str, ...]] = {
    "K1": (
        "M1",
        "K1",
        "cameraMatrix1",
        "camera_matrix_left",
        "left_camera_matrix",
        "cameraMatrixL",
        "cameraMatrixLeft",
        "K_left",
        "mtx_left",
        "mtxL",
    ),
    "D1": (
        "D1",
        "dist1",
        "distCoeffs1",
        "distortion_coefficients_left",
        "dist_coeffs_left",
        "distortion_left",
        "left_distortion_coefficients",
        "left_distortion",
        "distCoeffsL",
        "distCoeffsLeft",
        "D_left",
        "dist_left",
        "distL",
    ),
    "K2": (
        "M2",
        "K2",
        "cameraMatrix2",
        "camera_matrix_right",
        "right_camera_matrix",
        "cameraMatrixR",
        "cameraMatrixRight",
        "K_right",
        "mtx_right",
        "mtxR",
    ),
    "D2": (
        "D2",
        "dist2",
        "distCoeffs2",
        "distortion_coefficients_right",
        "dist_coeffs_right",
        "distortion_right",
        "right_distortion_coefficients",
        "right_distortion",
        "distCoeffsR",
        "distCoeffsRight",
        "D_right",
        "dist_right",
        "distR",
    ),
    "R": ("R", "R_stereo", "rotation"),
    "T": ("T", "T_stereo", "translation"),
}
#: Key names of a one-camera OpenCV file (OpenCV's ``calibration`` sample writes the first of each).
_CAMERA_ALIASES: dict[str, tuple[str, ...]] = {
    "K": ("camera_matrix", "cameraMatrix", "K", "M", "intrinsic_matrix", "mtx"),
    "D": ("distortion_coefficients", "distCoeffs", "dist_coeffs", "D", "distortion_coefficients_vector", "dist"),
}
#: The file-wide explicit choice of no distortion.
NO_DISTORTION_KEY = "distortion"


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


def _check_baseline(T: np.ndarray | None, key: tuple, issues: _Issues) -> None:
    if T is not None and np.linalg.norm(T) < 1e-6:
        issues.add(key, "zero baseline: the two cameras are at the same place")


def _size(w: Any, h: Any, key: tuple, issues: _Issues) -> tuple[int | None, int | None]:
    ok = all(
        isinstance(v, (int, float)) and not isinstance(v, bool) and float(v).is_integer() and v > 0 for v in (w, h)
    )
    if not ok:
        issues.add(key, f"image size must be two positive integers, got {w!r} x {h!r}")
        return None, None
    return int(w), int(h)


def _is_none(v: Any) -> bool:
    return isinstance(v, str) and v.strip().lower() == "none"


def _radtan(D: np.ndarray) -> np.ndarray:
    """OpenCV's (k1, k2, p1, p2) as the equivalent five (k3 = 0): one form for every file."""
    return np.append(D, 0.0) if D.size == 4 else D


# --------------------------------------------------------------------------- OpenCV FileStorage


def _is_filestorage(text: str) -> bool:
    head = text.lstrip()[:200]
    return (
        head.startswith("%YAML") or "!!opencv-matrix" in text or '"opencv-matrix"' in text or head.startswith("<?xml")
    )


def _read_filestorage(path: Path) -> tuple[dict[str, Any], list[tuple[str, str]]]:
    """Top-level entries of a FileStorage file as numpy arrays / numbers / strings,
    and ``(key, problem)`` for entries OpenCV cannot read."""
    import cv2  # only for OpenCV files and lens models: a HAL config loads without OpenCV

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


def _pick(entries: dict[str, Any], names: tuple[str, ...]) -> tuple[str | None, Any]:
    for name in names:
        if name in entries:
            return name, entries[name]
    return None, None


def _entries_size(entries: dict[str, Any], issues: _Issues) -> tuple[int | None, int | None]:
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


def _distortion(entries: dict[str, Any], names: tuple[str, ...], which: str, issues: _Issues) -> np.ndarray | None:
    """The distortion of one camera: its key, or the file's explicit ``distortion: none``;
    otherwise an error naming the keys looked for (never a silent zero)."""
    name, raw = _pick(entries, names)
    if name is None:
        if _is_none(entries.get(NO_DISTORTION_KEY)):
            return np.zeros(0)
        issues.add(
            (),
            f"missing the {which} distortion coefficients: looked for {', '.join(names)}; "
            f"write `{NO_DISTORTION_KEY}: none` if the lenses have none (the images are undistorted already)",
        )
        return None
    if _is_none(raw):
        return np.zeros(0)
    D = _matrix(raw, None, (name,), issues, vector=True)
    return None if D is None else _radtan(D)


def _rotation_entry(raw: Any) -> Any:
    if np.asarray(raw).size == 3:  # a Rodrigues vector
        import cv2  # only for OpenCV files and lens models: a HAL config loads without OpenCV

        return cv2.Rodrigues(np.asarray(raw, dtype=float).reshape(3, 1))[0]
    return raw


def _stereo_from_entries(entries: dict[str, Any], issues: _Issues, where: str) -> StereoCalibration:
    """One stereo calibration from the entries of one file (or an intrinsics + extrinsics pair)."""
    w, h = _entries_size(entries, issues)
    vals: dict[str, np.ndarray | None] = {}
    names: dict[str, str] = {}
    for role, shape in (("K1", (3, 3)), ("K2", (3, 3)), ("R", (3, 3)), ("T", (3, 1))):
        name, raw = _pick(entries, _ALIASES[role])
        if name is None:
            issues.add((), f"missing `{_ALIASES[role][0]}` (also accepted: {', '.join(_ALIASES[role][1:5])})")
            vals[role] = None
            continue
        names[role] = name
        vals[role] = _matrix(_rotation_entry(raw) if role == "R" else raw, shape, (name,), issues)
    vals["D1"] = _distortion(entries, _ALIASES["D1"], "left camera's", issues)
    vals["D2"] = _distortion(entries, _ALIASES["D2"], "right camera's", issues)
    _check_camera(vals["K1"], w, h, (names.get("K1", "M1"),), issues)
    _check_camera(vals["K2"], w, h, (names.get("K2", "M2"),), issues)
    _check_rotation(vals["R"], (names.get("R", "R"),), issues)
    _check_baseline(vals["T"], (names.get("T", "T"),), issues)
    issues.raise_if_any()
    K1, K2, D1, D2, R, T = (vals[k] for k in ("K1", "K2", "D1", "D2", "R", "T"))
    assert w is not None and h is not None and K1 is not None and K2 is not None and D1 is not None
    assert D2 is not None and R is not None and T is not None
    return StereoCalibration(
        CameraModel(w, h, K1, D1, "left"), CameraModel(w, h, K2, D2, "right"), R, T.reshape(3), where
    )


def _camera_from_entries(
    entries: dict[str, Any], issues: _Issues, which: str
) -> tuple[CameraModel | None, np.ndarray | None, np.ndarray | None]:
    """One camera of a per-camera OpenCV file (``camera_matrix``, ``distortion_coefficients``,
    ``image_width``/``image_height``), and its ``R``, ``T`` when the file holds them."""
    w, h = _entries_size(entries, issues)
    name, raw = _pick(entries, _CAMERA_ALIASES["K"])
    K = None
    if name is None:
        issues.add((), f"missing the {which} camera matrix: looked for {', '.join(_CAMERA_ALIASES['K'])}")
    else:
        K = _matrix(raw, (3, 3), (name,), issues)
        _check_camera(K, w, h, (name,), issues)
    D = _distortion(entries, _CAMERA_ALIASES["D"], f"{which} camera's", issues)
    R = T = None
    rn, rraw = _pick(entries, _ALIASES["R"])
    tn, traw = _pick(entries, _ALIASES["T"])
    if rn is not None:
        R = _matrix(_rotation_entry(rraw), (3, 3), (rn,), issues)
        _check_rotation(R, (rn,), issues)
    if tn is not None:
        T = _matrix(traw, (3, 1), (tn,), issues)
        _check_baseline(T, (tn,), issues)
    cam = None if (K is None or D is None or w is None or h is None) else CameraModel(w, h, K, D, which)
    return cam, R, None if T is None else T.reshape(3)


def _is_per_camera(entries: dict[str, Any]) -> bool:
    return _pick(entries, _CAMERA_ALIASES["K"])[0] is not None and _pick(entries, _ALIASES["K1"])[0] is None


def _from_filestorage(paths: list[Path]) -> StereoCalibration:
    read = []
    for p in paths:
        e, pr = _read_filestorage(p)
        text = p.read_text(encoding="utf-8", errors="replace")
        issues = _Issues(str(p), text)
        for key, msg in pr:
            issues.add((key,), msg)
        issues.raise_if_any()
        read.append((p, e, text))
    where = " + ".join(str(p) for p in paths)
    if len(read) == 2 and all(_is_per_camera(e) for _, e, _ in read):
        return _from_camera_pair(read)
    entries: dict[str, Any] = {}
    text = ""
    for _, e, t in read:
        entries.update(e)
        text += t
    if len(read) == 1 and _is_per_camera(entries):
        raise ConfigError(
            [
                ConfigIssue(
                    Mark(where, 1, 1),
                    (),
                    "this file holds one camera (camera_matrix): give the right camera's file too "
                    "(with R and T: X_right = R X_left + T)",
                )
            ]
        )
    return _stereo_from_entries(entries, _Issues(where, text), where)


def _from_camera_pair(read: list[tuple[Path, dict[str, Any], str]]) -> StereoCalibration:
    """Two per-camera OpenCV files; the right one holds R and T (X_right = R X_left + T)."""
    (pl, el, tl), (pr, er, tr) = read
    il, ir = _Issues(str(pl), tl), _Issues(str(pr), tr)
    left, _, _ = _camera_from_entries(el, il, "left")
    right, R, T = _camera_from_entries(er, ir, "right")
    if R is None and T is None and not ir.issues:
        ir.add(
            (), "missing R and T (the right camera's pose: X_right = R X_left + T, as OpenCV's stereoCalibrate gives)"
        )
    elif (R is None) != (T is None):
        ir.add((), f"missing {'R' if R is None else 'T'} beside {'T' if R is None else 'R'}")
    if left is not None and right is not None and left.size != right.size:
        ir.add(
            ("image_width",),
            f"the right camera's images are {right.width}x{right.height}, the left camera's "
            f"{left.width}x{left.height}: a stereo pair has one size",
        )
    issues = il.issues + ir.issues
    if issues:
        raise ConfigError(issues)
    assert left is not None and right is not None and R is not None and T is not None
    return StereoCalibration(left, right, R, T, f"{pl} + {pr}")


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


_ROS_MODELS = {"plumb_bob": "radtan", "rational_polynomial": "radtan", "equidistant": "equidistant"}


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
    model_name = data.get("distortion_model", "plumb_bob")
    model = _ROS_MODELS.get(str(model_name))
    if model is None:
        issues.add(
            ("distortion_model",),
            f"unsupported distortion model `{model_name}` (plumb_bob, rational_polynomial or equidistant)",
        )
    elif model == "equidistant" and D is not None and D.size != 4:
        issues.add(("distortion_coefficients",), f"the equidistant model has 4 coefficients, got {D.size}")
        D = None
    _check_camera(K, w, h, ("camera_matrix",), issues)
    _check_rotation(Rr, ("rectification_matrix",), issues)
    if P is not None and not P[0, 0] > 0:
        issues.add(("projection_matrix",), "P[0][0] (rectified fx) must be positive")
    cam = (
        None
        if (K is None or D is None or w is None or h is None or model is None)
        else CameraModel(w, h, K, _radtan(D) if model == "radtan" else D, str(data.get("camera_name") or ""), model)
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


# --------------------------------------------------------------------------- Kalibr camchain


def _is_kalibr(data: Any) -> bool:
    return isinstance(data, dict) and isinstance(data.get("cam0"), dict) and "intrinsics" in data["cam0"]


_KALIBR_DISTORTION = {"radtan": ("radtan", 4), "equidistant": ("equidistant", 4), "none": ("radtan", 0)}


def _kalibr_camera(src: Located, key: str, issues: _Issues, name: str) -> CameraModel | None:
    cam = src.data.get(key)
    if not isinstance(cam, dict):
        issues.add((key,) if key in src.data else (), f"missing `{key}` (a stereo camchain has cam0 and cam1)")
        return None
    ok = True
    for field_name in ("camera_model", "intrinsics", "distortion_model", "distortion_coeffs", "resolution"):
        if field_name not in cam:
            issues.add((key,), f"missing `{field_name}` (Kalibr camchain)")
            ok = False
    if not ok:
        return None
    if cam["camera_model"] != "pinhole":
        issues.add((key, "camera_model"), f"camera model `{cam['camera_model']}` is not supported (pinhole only)")
        return None
    dm = cam["distortion_model"]
    if dm not in _KALIBR_DISTORTION:
        issues.add((key, "distortion_model"), f"distortion model `{dm}` is not supported (radtan, equidistant or none)")
        return None
    model, n = _KALIBR_DISTORTION[dm]
    intr = (
        _matrix(cam["intrinsics"], None, (key, "intrinsics"), issues) if isinstance(cam["intrinsics"], list) else None
    )
    if intr is None or intr.size != 4:
        issues.add((key, "intrinsics"), "expected [fu, fv, pu, pv]")
        return None
    coeffs = cam["distortion_coeffs"]
    if not isinstance(coeffs, list) or len(coeffs) != n:
        issues.add((key, "distortion_coeffs"), f"distortion model `{dm}` has {n} coefficients, got {coeffs!r}")
        return None
    D = _matrix(coeffs, None, (key, "distortion_coeffs"), issues) if n else np.zeros(0)
    res = cam["resolution"]
    if not isinstance(res, list) or len(res) != 2:
        issues.add((key, "resolution"), "expected [width, height]")
        return None
    w, h = _size(res[0], res[1], (key, "resolution"), issues)
    if D is None or w is None or h is None:
        return None
    fu, fv, pu, pv = intr
    K = np.array([[fu, 0.0, pu], [0.0, fv, pv], [0.0, 0.0, 1.0]])
    _check_camera(K, w, h, (key, "intrinsics"), issues)
    return CameraModel(w, h, K, _radtan(D.reshape(-1)) if model == "radtan" else D.reshape(-1), name, model)


def _from_kalibr(src: Located) -> StereoCalibration:
    """A Kalibr ``camchain.yaml``: cam0 is the left camera (the rig frame), cam1 the right;
    ``cam1.T_cn_cnm1`` maps cam0 points into cam1 (X_1 = T X_0), OpenCV's R, T."""
    issues = _Issues(src.file, located=src)
    left = _kalibr_camera(src, "cam0", issues, "left")
    right = _kalibr_camera(src, "cam1", issues, "right")
    R = T = None
    cam1 = src.data.get("cam1")
    if isinstance(cam1, dict):
        if "T_cn_cnm1" not in cam1:
            issues.add(("cam1",), "missing `T_cn_cnm1` (the pose of cam1 relative to cam0)")
        else:
            M = _matrix(cam1["T_cn_cnm1"], (4, 4), ("cam1", "T_cn_cnm1"), issues)
            if M is not None:
                if np.abs(M[3] - np.array([0.0, 0.0, 0.0, 1.0])).max() > 1e-9:
                    issues.add(("cam1", "T_cn_cnm1"), "the last row of a homogeneous transform must be [0, 0, 0, 1]")
                R, T = M[:3, :3].copy(), M[:3, 3].copy()
                _check_rotation(R, ("cam1", "T_cn_cnm1"), issues)
                _check_baseline(T, ("cam1", "T_cn_cnm1"), issues)
    if left is not None and right is not None and left.size != right.size:
        issues.add(("cam1", "resolution"), f"cam0 is {left.width}x{left.height}, cam1 {right.width}x{right.height}")
    issues.raise_if_any()
    assert left is not None and right is not None and R is not None and T is not None
    return StereoCalibration(left, right, R, T, src.file)


# --------------------------------------------------------------------------- entry points


def load_stereo_calibration(path: str | Path, right_path: str | Path | None = None) -> StereoCalibration:
    """Read a stereo calibration (see :mod:`vision.calibration` for the formats).

    ``path`` alone: an OpenCV FileStorage file with both cameras, a Kalibr
    ``camchain.yaml``, or a plain YAML file with the FileStorage key names.
    With ``right_path``: two ROS ``camera_info`` files (left, right), two
    per-camera OpenCV files (the right one with R and T), or OpenCV's
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
    if len(docs) == 1 and _is_kalibr(docs[0].data):
        return _from_kalibr(docs[0])
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
        return _from_plain(docs)
    raise ConfigError(
        [
            ConfigIssue(
                Mark(str(paths[0]), 1, 1),
                (),
                "not a stereo calibration: expected an OpenCV FileStorage file (M1, D1, M2, D2, R, T; or one "
                "file per camera), a Kalibr camchain.yaml (cam0, cam1) or two ROS camera_info files",
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


def _from_plain(docs: list[Located]) -> StereoCalibration:
    """Hand-written YAML: the FileStorage key names with nested lists as matrices."""
    entries: dict[str, Any] = {}
    for d in docs:
        entries.update(d.data)
    src = (
        docs[0]
        if len(docs) == 1
        else Located(entries, " + ".join(d.file for d in docs), {k: v for d in docs for k, v in d.marks.items()})
    )
    issues = _Issues(src.file, located=src)
    converted = {
        k: (np.asarray(v, dtype=float) if isinstance(v, list) and _numeric(v) else v) for k, v in entries.items()
    }
    for k, v in entries.items():
        if isinstance(v, list) and not _numeric(v):
            issues.add((k,), "expected a list of numbers or a list of rows")
    issues.raise_if_any()
    return _stereo_from_entries(converted, issues, src.file)


def _numeric(v: Any) -> bool:
    flat = v if not v or not isinstance(v[0], list) else [x for row in v if isinstance(row, list) for x in row]
    return all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in flat) and (
        not v or not isinstance(v[0], list) or all(isinstance(r, list) for r in v)
    )


def save_stereo_calibration(calib: StereoCalibration, path: str | Path) -> Path:
    """Write an OpenCV FileStorage file (YAML, or JSON for a ``.json`` path) with
    ``M1 D1 M2 D2 R T image_width image_height`` (``distortion: none`` when both
    cameras have none), readable by OpenCV and by :func:`load_stereo_calibration`.
    Radial-tangential cameras only (OpenCV's stereo files have no fisheye flag)."""
    import cv2  # only for OpenCV files and lens models: a HAL config loads without OpenCV

    if calib.left.model != "radtan" or calib.right.model != "radtan":
        raise ValueError("an OpenCV stereo file holds radial-tangential cameras only; this rig is equidistant")
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    fs = cv2.FileStorage(str(p), cv2.FILE_STORAGE_WRITE)
    try:
        fs.write("image_width", int(calib.left.width))
        fs.write("image_height", int(calib.left.height))
        fs.write("M1", np.asarray(calib.left.K, dtype=float))
        if calib.left.D.size:
            fs.write("D1", np.asarray(calib.left.D, dtype=float).reshape(1, -1))
        fs.write("M2", np.asarray(calib.right.K, dtype=float))
        if calib.right.D.size:
            fs.write("D2", np.asarray(calib.right.D, dtype=float).reshape(1, -1))
        if not calib.left.D.size or not calib.right.D.size:
            fs.write(NO_DISTORTION_KEY, "none")
        fs.write("R", np.asarray(calib.R, dtype=float))
        fs.write("T", np.asarray(calib.T, dtype=float).reshape(3, 1))
    finally:
        fs.release()
    return p
