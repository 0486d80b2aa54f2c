"""`maris validate` and `maris show`: exit codes, every error printed, no traceback."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from mission.cli import main

ROOT = Path(__file__).resolve().parents[2]
MARIS = ROOT / "missions" / "maris_pipe_recovery.yaml"

BAD = """\
name: bad
safety:
  max_depth_m: 4
  min_altitude_m: 0.5
  max_duration_s: 60
  geofence: {north_m: [0, 1], east_m: [0, 1], down_m: [0, 4]}
tree:
  sequence:
    children:
      - action: {run: grap, timeout_s: 3}
      - gripper: {command: clse}
"""


def test_validate_ok(capsys):
    assert main(["validate", str(MARIS)]) == 0
    assert "is valid" in capsys.readouterr().out


def test_validate_several_files(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text(BAD)
    shipped = sorted(str(p) for p in (ROOT / "missions").glob("*.yaml"))
    assert main(["validate", *shipped]) == 0
    assert capsys.readouterr().out.count("is valid") == len(shipped)
    assert main(["validate", str(bad), *shipped]) == 1
    captured = capsys.readouterr()
    assert captured.out.count("is valid") == len(shipped) and "3 problems found" in captured.err


def test_validate_prints_every_error_and_fails(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text(BAD)
    assert main(["validate", str(bad)]) == 1
    err = capsys.readouterr().err.splitlines()
    assert f"{bad}:10:23: tree.sequence.children[0].action.run: unknown action `grap` (did you mean `grasp`?)" in err[1]
    assert any("did you mean `close`" in line for line in err)
    assert any("missing required section `abort`" in line for line in err)
    assert err[-1] == f"{bad}: 3 problems found"


def test_validate_missing_file(tmp_path, capsys):
    assert main(["validate", str(tmp_path / "nope.yaml")]) == 1
    assert "cannot read file" in capsys.readouterr().err


def test_validate_with_hal_config(tmp_path, capsys):
    hal = tmp_path / "hal.yaml"
    hal.write_text("devices:\n  vehicle: {driver: sim}\n  arm: {driver: sim}\nsim: {scenario: pool_clear}\n")
    assert main(["validate", str(MARIS), "--hal", str(hal)]) == 1
    err = capsys.readouterr().err
    assert "needs device role(s) detector" in err and "needs device role(s) gripper" in err
    broken = tmp_path / "broken.yaml"
    broken.write_text("devices:\n  vehicle: {drivr: sim}\n")
    assert main(["validate", str(MARIS), "--hal", str(broken)]) == 1
    assert "broken.yaml:2" in capsys.readouterr().err


def test_show_prints_both_trees_and_writes_dot(tmp_path, capsys):
    dot = tmp_path / "tree.dot"
    assert main(["show", str(MARIS), "--dot", str(dot)]) == 0
    out = capsys.readouterr().out
    assert "Survey until the pipe is seen" in out and "abort path:" in out and "Safe recovery" in out
    assert "safety: depth <= 4 m" in out and "blackboard: grasp_pose: pose, grasp_attempts: int = 0" in out
    text = dot.read_text()
    assert text.startswith("digraph") and "Hand currents confirm the grasp" in text


@pytest.mark.slow
def test_show_png_without_graphviz_draws_it_with_matplotlib(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(shutil, "which", lambda name: None)
    png = tmp_path / "t.png"
    assert main(["show", str(MARIS), "--png", str(png)]) == 0
    assert f"wrote {png}" in capsys.readouterr().out
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert main(["show", str(MARIS), "--png", str(tmp_path / "missing" / "t.png")]) == 1
    err = capsys.readouterr().err
    assert "cannot write" in err and "Traceback" not in err


def test_tree_layout_centres_parents_on_their_children():
    import py_trees

    from mission.tree_png import place

    leaves = [py_trees.behaviours.Success(f"leaf{i}") for i in range(3)]
    inner = py_trees.composites.Selector("inner", memory=False, children=leaves[1:])
    root = py_trees.composites.Sequence("root", memory=True, children=[leaves[0], inner])
    placed, rows = place(root)
    assert rows == 3
    assert [c.row for c in placed.children] == [0.0, 1.5]
    assert placed.row == 0.75 and placed.children[1].kind == "selector" and placed.children[1].depth == 1


@pytest.mark.skipif(shutil.which("dot") is None, reason="graphviz `dot` not installed")
def test_show_png_with_graphviz(tmp_path):
    png = tmp_path / "t.png"
    assert main(["show", str(MARIS), "--png", str(png)]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.slow
def test_bad_input_never_prints_a_traceback(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("tree: !!python/object/apply:os.system ['echo pwned']\n")
    for cmd in ("validate", "show"):
        proc = subprocess.run(
            [sys.executable, "-m", "mission.cli", cmd, str(bad)], capture_output=True, text=True, timeout=60
        )
        assert proc.returncode == 1
        assert "Traceback" not in proc.stderr and "pwned" not in proc.stdout
        assert f"{bad}:1:7" in proc.stderr
