"""``maris calibrate``: recover known simulator parameters from logs the simulator wrote."""

from __future__ import annotations

import numpy as np
import pytest

from mission.calibration.fit import sample_rate, simulate_response, white_noise_std
from mission.cli import main
from mission.runtime.options import RunOptions, RunTarget

KNOWN = """
extends: pool_fixed
vehicle:
  model: first_order
  time_constant_s: [1.2, 0.6, 0.5, 0.3, 0.3, 0.8]
  dead_band: [0.02, 0.02, 0.02, 0.005, 0.005, 0.01]
  low_speed_gain: [0.5, 0.5, 0.5, 0.7, 0.7, 0.6]
dvl:
  rate_hz: 4.0
  noise_std_mps: 0.02
  dropout_probability: 0.1
ahrs:
  rate_noise_std_rad_s: 0.006
"""


@pytest.fixture(scope="module")
def known_log(tmp_path_factory):
    """One dry run of the reference mission on a first-order vehicle with known parameters."""
    from mission.runtime.api import run_mission

    d = tmp_path_factory.mktemp("cal")
    scen = d / "known.yaml"
    scen.write_text(KNOWN)
    log = d / "known.mcap"
    run_mission(RunTarget("missions/maris_pipe_recovery.yaml", scenario=str(scen), seed=3), RunOptions(log_path=log))
    return log


@pytest.mark.slow
def test_recovers_known_parameters(known_log, tmp_path, capsys):
    from sim_backend import load_scenario

    out = tmp_path / "fitted.yaml"
    assert main(["calibrate", str(known_log), "--base", "pool_fixed", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "u.time_constant_s" in printed and f"wrote {out}" in printed
    s = load_scenario(out)  # a valid scenario, usable with --scenario
    assert s["vehicle.model"] == "first_order"
    tau = s["vehicle.time_constant_s"]
    assert tau[0] == pytest.approx(1.2, rel=0.15)  # surge, from the DVL
    assert tau[2] == pytest.approx(0.5, rel=0.2)  # heave
    assert tau[5] == pytest.approx(0.8, rel=0.15)  # yaw, from the gyro
    assert s["dvl.rate_hz"] == pytest.approx(4.0, rel=0.01)
    assert s["dvl.noise_std_mps"] == pytest.approx(0.02, rel=0.15)
    assert s["dvl.dropout_probability"] == pytest.approx(0.1, abs=0.05)
    assert s["ahrs.rate_noise_std_rad_s"] == pytest.approx(0.006, rel=0.1)
    assert 0.8 < s["vision.detection_probability"]["clear"] <= 1.0
    text = out.read_text()
    assert "extends: pool_fixed" in text and "+-" in text and "not fitted" in text  # sway is never commanded


def test_bad_input_is_a_clear_error(tmp_path, capsys):
    assert main(["calibrate", str(tmp_path / "missing.mcap")]) == 1
    assert "no such file" in capsys.readouterr().err
    junk = tmp_path / "junk.mcap"
    junk.write_text("not a log")
    assert main(["calibrate", str(junk), "--out", str(tmp_path / "x.yaml")]) == 1
    err = capsys.readouterr().err
    assert "maris calibrate" in err and "Traceback" not in err


def test_pure_fits():
    rng = np.random.default_rng(0)
    assert white_noise_std(np.sin(np.linspace(0, 3, 4000)) + 0.03 * rng.standard_normal(4000)).value == pytest.approx(
        0.03, rel=0.05
    )
    t = np.arange(0, 100, 0.2)
    keep = rng.random(t.size) > 0.2
    rate, lost = sample_rate(t[keep])
    assert rate.value == pytest.approx(5.0) and lost.value == pytest.approx(0.2, abs=0.05)
    # the response model: a step settles to the gain at its size with the time constant
    tc = np.array([0.0, 1.0])
    v = simulate_response(tc, np.array([0.0, 0.3]), np.array([1.0 + 0.8, 30.0]), 0.8, 0.0, 1.0, 0.05)
    assert v[0] == pytest.approx(0.3 * (1 - np.exp(-1)), rel=0.02) and v[1] == pytest.approx(0.3, rel=1e-3)
