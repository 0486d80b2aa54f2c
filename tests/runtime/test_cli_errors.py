"""Bad user input to `maris sim` / `maris run`: a clear message, exit code 2, no traceback, no log."""

from __future__ import annotations

import pytest

from mission.cli import main

from .conftest import ROOT

SURVEY = str(ROOT / "missions" / "survey_only.yaml")


@pytest.mark.parametrize(
    "argv, expected",
    [
        (["sim", str(ROOT / "missions" / "nope.yaml")], "nope.yaml:1:1: <root>: cannot read file"),
        (["sim", SURVEY, "--scenario", "pool_fixd"], "did you mean `pool_fixed`?"),
        (
            ["sim", SURVEY, "--set", "dvl.dropots=[[1, 2]]"],
            "dvl.dropots: unknown scenario parameter (did you mean `dvl.dropouts`?)",
        ),
        (["sim", SURVEY, "--set", "novalue"], "--set expects KEY=VALUE"),
        (["sim", SURVEY, "--filter-cutoff", "-3"], "--filter-cutoff must be positive"),
        (["sim", SURVEY, "--log-hz", "0"], "--log-hz must be positive"),
        (["run", SURVEY, "--hal", str(ROOT / "missing_hal.yaml")], "missing_hal.yaml:1:1"),
        (["sim", SURVEY, "--inject", "dvl_dropot@3"], "unknown fault `dvl_dropot`"),
        (["sim", SURVEY, "--inject", "dvl_dropout@-1"], "T must be >= 0"),
        (["sim", SURVEY, "--inject", "joint_fault:nojoint@3"], "unknown joint 'nojoint'"),
    ],
)
def test_bad_input_is_a_clear_error(argv, expected, tmp_path, capsys):
    log = tmp_path / "x.mcap"
    assert main(argv + ["--log", str(log)]) == 2
    err = capsys.readouterr().err
    assert expected in err and "Traceback" not in err
    assert not log.exists()


def test_bad_mission_field_names_file_line_column(tmp_path, capsys):
    text = (ROOT / "missions" / "survey_only.yaml").read_text().replace("max_depth_m: 4.0", "max_depth_m: deep")
    bad = tmp_path / "bad.yaml"
    bad.write_text(text)
    line = next(i for i, l in enumerate(text.splitlines(), 1) if "max_depth_m: deep" in l)
    assert main(["sim", str(bad), "--no-log"]) == 2
    err = capsys.readouterr().err
    assert f"bad.yaml:{line}:" in err and "max_depth_m" in err


def test_injected_fault_from_the_command_line(tmp_path, capsys):
    log = tmp_path / "nan.mcap"
    # before the survey can first see the pipe (about 1 s in, once the arm is folded out of view)
    assert main(["sim", SURVEY, "--inject", "ahrs_nan@0.5", "--log", str(log), "--quiet"]) == 1
    out = capsys.readouterr().out
    assert "outcome:   aborted  (non_finite (navigation)" in out
    assert log.exists()


def test_unwritable_log_path_is_a_clear_error(tmp_path, capsys):
    """Checked before the run starts: a file where a folder should be, or a folder as --log."""
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    assert main(["sim", SURVEY, "--log", str(blocker / "run.mcap"), "--quiet"]) == 2
    assert main(["sim", SURVEY, "--log", str(tmp_path), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert f"cannot create the log folder {blocker}" in err
    assert f"--log {tmp_path} is a folder" in err and "Traceback" not in err


@pytest.mark.parametrize("problem", ["log path is a folder", "bad --log-hz", "bad mission field"])
def test_maris_run_closes_the_devices_when_setup_fails_before_the_run(problem, tmp_path, monkeypatch, capsys):
    """`maris run` opened the buses and links when it built the backend: an error
    found afterwards (log path, options, the mission itself) still closes them."""
    import hal.factory

    built = []
    real_build = hal.factory.build_backend

    def recording_build(*a, **kw):
        backend = real_build(*a, **kw)
        closes = []
        original_close = backend.close
        backend.close = lambda: (closes.append(1), original_close())
        built.append(closes)
        return backend

    monkeypatch.setattr(hal.factory, "build_backend", recording_build)
    mission, extra = SURVEY, []
    if problem == "log path is a folder":
        extra = ["--log", str(tmp_path)]
    elif problem == "bad --log-hz":
        extra = ["--log-hz", "0"]
    else:
        bad = tmp_path / "bad.yaml"
        bad.write_text(
            (ROOT / "missions" / "survey_only.yaml").read_text().replace("max_depth_m: 4.0", "max_depth_m: deep")
        )
        mission = str(bad)
    assert main(["run", mission, "--hal", str(ROOT / "hal" / "configs" / "sim.yaml"), "--quiet", *extra]) == 2
    assert "Traceback" not in capsys.readouterr().err
    assert len(built) == 1 and len(built[0]) >= 1
