"""`maris vision`: detect on pairs and folders, tune, calib, render; bad input never a traceback."""

from __future__ import annotations

import csv
import json
import shutil
from pathlib import Path

import cv2
import pytest

from mission.cli import main


@pytest.fixture(scope="module")
def pair(tmp_path_factory) -> Path:  # noqa: ANN001
    out = tmp_path_factory.mktemp("render")
    assert main(["vision", "render", str(out), "--range", "1.2"]) == 0
    return out


@pytest.mark.slow
def test_detect_on_a_rendered_pair_writes_overlay_and_poses(pair: Path, tmp_path: Path, capsys) -> None:  # noqa: ANN001
    out = tmp_path / "det"
    rc = main(
        [
            "vision",
            "detect",
            str(pair / "calibration.yaml"),
            str(pair / "left.png"),
            str(pair / "right.png"),
            "--out",
            str(out),
            "--attitude",
            "0,0",
        ]
    )
    text = capsys.readouterr().out
    assert rc == 0, text
    assert "pipe found in 1" in text
    rows = list(csv.DictReader(open(out / "poses.csv")))
    truth = json.loads((pair / "truth.json").read_text())["cam_T_grasp"]
    assert len(rows) == 1 and float(rows[0]["confidence"]) > 0.6
    err = sum((float(rows[0][k]) - truth[i][3]) ** 2 for i, k in enumerate(("x_m", "y_m", "z_m"))) ** 0.5
    assert err < 0.01
    assert json.loads((out / "poses.json").read_text())[0]["cam_T_grasp"] is not None
    img = cv2.imread(str(out / "overlay_000000.png"))
    assert img is not None and img.shape == (482, 646, 3)


def test_folders_with_a_corrupt_frame_and_a_pair_of_other_sizes(pair: Path, tmp_path: Path, capsys) -> None:  # noqa: ANN001
    L, R = tmp_path / "L", tmp_path / "R"
    L.mkdir()
    R.mkdir()
    for i in range(3):
        shutil.copy(pair / "left.png", L / f"{i}.png")
        shutil.copy(pair / "right.png", R / f"{i}.png")
    (L / "1.png").write_bytes(b"not a png at all")
    small = cv2.imread(str(pair / "right.png"))[:, :600]
    cv2.imwrite(str(R / "2.png"), small)
    rc = main(
        [
            "vision",
            "detect",
            str(pair / "calibration.yaml"),
            str(L),
            str(R),
            "--out",
            str(tmp_path / "o"),
            "--no-overlay",
        ]
    )
    cap = capsys.readouterr()
    assert rc == 1
    assert "pair 1 (1.png): " in cap.err and "cannot decode the image" in cap.err
    assert "pair 2 (2.png): image sizes differ: left 646x482, right 600x482" in cap.err
    assert "3 pair(s): pipe found in 1, not found in 0, unreadable 2" in cap.out
    assert "Traceback" not in cap.err


def test_no_pipe_is_a_zero_confidence_row(pair: Path, tmp_path: Path, capsys) -> None:  # noqa: ANN001
    blank = cv2.imread(str(pair / "left.png"))
    blank[:] = (120, 130, 110)
    cv2.imwrite(str(tmp_path / "l.png"), blank)
    cv2.imwrite(str(tmp_path / "r.png"), blank)
    rc = main(
        [
            "vision",
            "detect",
            str(pair / "calibration.yaml"),
            str(tmp_path / "l.png"),
            str(tmp_path / "r.png"),
            "--out",
            str(tmp_path / "o"),
        ]
    )
    assert rc == 0
    with open(tmp_path / "o" / "poses.csv") as f:
        row = next(csv.DictReader(f))
    assert float(row["confidence"]) == 0.0 and "no pipe in view" in row["reason"] and row["x_m"] == ""
    assert "not found in 1" in capsys.readouterr().out


def test_bad_files_exit_2_with_one_line(pair: Path, tmp_path: Path, capsys) -> None:  # noqa: ANN001
    bad = tmp_path / "cal.yaml"
    bad.write_text(
        "%YAML:1.0\n---\nimage_width: 646\nimage_height: 482\nM1: !!opencv-matrix\n   rows: 3\n   cols: 4\n   dt: d\n"
        "   data: [ 1., 0., 0., 0., 0., 1., 0., 0., 0., 0., 1., 0. ]\n"
    )
    assert main(["vision", "detect", str(bad), str(pair / "left.png"), str(pair / "right.png")]) == 2
    err = capsys.readouterr().err
    assert "cal.yaml:5:1: M1: expected a 3x3 matrix, got 3x4" in err and "Traceback" not in err
    assert (
        main(["vision", "detect", str(pair / "calibration.yaml"), str(tmp_path / "none.png"), str(pair / "right.png")])
        == 2
    )
    assert "none.png: no such file or folder" in capsys.readouterr().err
    assert main(["vision", "tune", str(tmp_path / "none.png")]) == 2


def test_tune_and_calib(pair: Path, tmp_path: Path, capsys) -> None:  # noqa: ANN001
    assert main(["vision", "tune", str(pair / "left.png"), "--out", str(tmp_path / "t")]) == 0
    out = capsys.readouterr().out
    assert "suggested hue" in out and (tmp_path / "t" / "mask_suggested.png").is_file()
    assert main(["vision", "calib", str(pair / "calibration.yaml")]) == 0
    out = capsys.readouterr().out
    assert "baseline 0.2000 m" in out and "646x482" in out and "rectified: focal" in out
