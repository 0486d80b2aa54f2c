"""Property tests (hypothesis) of the vehicle kinematics and the scenario overrides,
and the ``python -m sim_backend`` helper."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from simtest_util import PERFECT_TRACKING

from sim_backend import SimBackend, load_scenario
from sim_backend.__main__ import main as cli_main
from sim_backend.geometry import rotation_rpy, rpy_from_rotation

speeds = st.floats(-0.3, 0.3, allow_nan=False)


@pytest.mark.slow
@settings(max_examples=30, deadline=None)
@given(u=speeds, v=speeds, w=speeds, yaw=st.floats(-math.pi, math.pi))
def test_constant_linear_velocity_moves_along_the_heading(model, u, v, w, yaw):
    sim = SimBackend(
        load_scenario("pool_fixed", {**PERFECT_TRACKING, "vehicle.start_yaw_rad": yaw, "vehicle.start_z_m": 2.0}),
        0,
        model=model,
    )
    sim.devices.vehicle.arm()
    p0 = sim.vehicle.eta[:3].copy()
    sim.devices.vehicle.command_body_velocity(np.array([u, v, w, 0, 0, 0]))
    for _ in range(100):
        sim.advance(0.01)
    expected = p0 + rotation_rpy(0.0, 0.0, yaw) @ np.array([u, v, w]) * 1.0
    assert np.allclose(sim.vehicle.eta[:3], expected, atol=1e-9)


@settings(max_examples=50, deadline=None)
@given(st.floats(-1.5, 1.5), st.floats(-1.5, 1.5), st.floats(-math.pi, math.pi))
def test_rpy_round_trip(roll, pitch, yaw):
    assert np.allclose(rpy_from_rotation(rotation_rpy(roll, pitch, yaw)), (roll, pitch, yaw), atol=1e-9)


@settings(max_examples=20, deadline=None)
@given(st.floats(0.0, 1.0), st.floats(0.1, 100.0))
def test_valid_overrides_are_taken_and_pickled(noise, rate):
    import pickle

    sc = load_scenario("pool_clear", {"dvl.noise_std_mps": noise, "dvl.rate_hz": str(rate)})
    assert sc["dvl.noise_std_mps"] == noise and sc["dvl.rate_hz"] == rate
    assert pickle.loads(pickle.dumps(sc)) == sc


def test_module_cli(capsys, tmp_path):
    assert cli_main(["list"]) == 0
    assert "pool_no_dvl" in capsys.readouterr().out
    assert cli_main(["show", "pool_clear", "--seed", "4", "--set", "dvl.noise_std_mps=0.05"]) == 0
    out = capsys.readouterr().out
    assert "dvl.noise_std_mps = 0.05" in out and "-> seed 4:" in out
    bad = tmp_path / "s.yaml"
    bad.write_text("dvl:\n  noise: 1\n")
    assert cli_main(["check", str(bad)]) == 2
    assert f"{bad}:2:10: dvl.noise:" in capsys.readouterr().err
