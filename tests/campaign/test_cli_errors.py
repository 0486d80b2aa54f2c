"""`maris campaign` rejects bad input with file:line:column / --set:N:COL messages, no traceback."""

from pathlib import Path

from mission.cli import main

REPO = Path(__file__).resolve().parents[2]
MISSION = str(REPO / "missions" / "maris_pipe_recovery.yaml")


def test_all_problems_at_once(capsys, tmp_path):
    rc = main(
        [
            "campaign",
            MISSION,
            "--scenario",
            "pool_clear",
            "--out",
            str(tmp_path / "o"),
            "--set",
            "pipe.x_mm=3",
            "--set",
            "controller.compensation=2",
            "--set",
            "vision.turbidity=murky",
        ]
    )
    err = capsys.readouterr().err
    assert rc == 2 and "Traceback" not in err
    assert "--set:1:1: pipe.x_mm: unknown scenario parameter (did you mean `pipe.x_m`?)" in err
    assert "--set:2:25: controller.compensation: expected true or false, got 2" in err
    assert "--set:3:1: vision.turbidity:" in err
    assert not (tmp_path / "o").exists()


def test_unknown_scenario_and_missing_mission(capsys):
    assert main(["campaign", "nope.yaml", "--scenario", "pool_clera"]) == 2
    err = capsys.readouterr().err
    assert "nope.yaml:1:1: <root>: mission file not found" in err
    assert "did you mean `pool_clear`?" in err


def test_broken_mission_file_names_line(capsys, tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("version: 1\nname: x\ntree:\n  sequence:\n    children: [ {bogus_node: {}} ]\n")
    assert main(["campaign", str(bad), "--scenario", "pool_clear"]) == 2
    err = capsys.readouterr().err
    assert f"{bad}:" in err and "Traceback" not in err


def test_argument_checks(capsys):
    assert main(["campaign", MISSION, "--scenario", "pool_clear", "--runs", "0"]) == 2
    assert main(["campaign", MISSION, "--scenario", "pool_clear", "--workers", "0"]) == 2
    assert main(["campaign", MISSION]) == 2
    assert main(["campaign", "--paper", MISSION]) == 2
    err = capsys.readouterr().err
    assert "--runs must be >= 1" in err and "--workers must be >= 1" in err and "--scenario is required" in err


def test_unusable_output_directory(capsys, tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    assert main(["campaign", MISSION, "--scenario", "pool_clear", "--runs", "1", "--out", str(blocker / "o")]) == 2
    err = capsys.readouterr().err
    assert "cannot create the output directory" in err and "Traceback" not in err
