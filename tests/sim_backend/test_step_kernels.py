"""The simulator's compiled per-step kernels give the numbers of the Python/numpy code
they replaced, bit for bit (same arithmetic in the same order, same random draws)."""

from __future__ import annotations

import math

import numpy as np

from sim_backend import load_scenario
from sim_backend.arm_sim import ArmJoints
from sim_backend.gyro import GyroNoise
from sim_backend.rng import NormalBlock, child_rng
from sim_backend.scenario import sample_values
from sim_backend.sensors import Ahrs


def _params() -> dict:
    p = sample_values(load_scenario("pool_clear"), 3)
    p["ahrs.vibration_rad_s"] = 0.01  # the vibration line on
    return p


def test_ahrs_sample_matches_the_python_reference() -> None:
    p = _params()
    ahrs = Ahrs(p, child_rng(5, "ahrs"))
    rng = child_rng(5, "ahrs")  # the reference: the former Python code on the same stream
    gyro = GyroNoise(p, rng)
    normals = NormalBlock(rng, 4096)
    drift = [0.0, 0.0]
    draws = np.random.default_rng(0)
    for k in range(1000):  # crosses a refill of the 4096-sample block
        t = round(0.01 * k, 9)
        eta, nu = draws.normal(size=6) * 3.0, draws.normal(size=6)
        level = float(draws.random())
        nav = None if k % 3 == 0 else draws.normal(size=2)
        ahrs.update(t, eta, nu, level, nav)
        n = normals.take_list(13)
        an = ahrs.att_noise
        yaw = eta[5] + an[2] * n[2]
        att = (eta[3] + an[0] * n[0], eta[4] + an[1] * n[1], (yaw + math.pi) % (2.0 * math.pi) - math.pi)
        g = gyro.sample(t, n[7:13], level)
        rates = [nu[3 + i] + g[i] for i in range(3)]
        depth = eta[2] + ahrs.depth_noise * n[6]
        if nav is None:
            drift[0] += ahrs.drift_step * n[3]
            drift[1] += ahrs.drift_step * n[4]
            pos = (eta[0] + drift[0], eta[1] + drift[1], depth)
        else:
            pos = (nav[0], nav[1], depth)
        assert ahrs.t == t and ahrs.depth == depth
        assert (
            np.array_equal(ahrs.attitude, att)
            and np.array_equal(ahrs.rates, rates)
            and np.array_equal(ahrs.position, pos)
        )


def _reference_arm_step(arm: dict, h: float, alpha: float) -> None:
    """ArmJoints.step as it was in numpy."""
    if not arm["command"].any():
        if not arm["qdot"].any():
            return
        if float(np.abs(arm["qdot"]).max()) < 1e-12:
            arm["qdot"][:] = 0.0
            return
    if arm["enabled"]:
        target = arm["command"] * arm["healthy"]
        arm["qdot"] += (target - arm["qdot"]) * alpha
        arm["qdot"] *= arm["healthy"]
    else:
        arm["qdot"][:] = 0.0
    q = arm["q"]
    q += arm["qdot"] * h
    low, high = q < arm["lower"], q > arm["upper"]
    if low.any() or high.any():
        np.clip(q, arm["lower"], arm["upper"], out=q)
        arm["qdot"][low | high] = 0.0


def test_arm_step_and_command_match_the_numpy_reference() -> None:
    p = _params()
    n = 5
    lower, upper, vmax = -np.ones(n), np.ones(n), np.full(n, 0.5)
    arm = ArmJoints(p, lower, upper, vmax, np.zeros(n))
    arm.enabled = True
    ref = {
        "q": arm.q.copy(),
        "qdot": arm.qdot.copy(),
        "command": np.zeros(n),
        "healthy": np.ones(n),
        "lower": lower,
        "upper": upper,
        "enabled": True,
    }
    h = 0.01
    alpha = 1.0 - math.exp(-h / arm.tau)
    draws = np.random.default_rng(1)
    for k in range(3000):
        if k % 50 == 0:  # new references: some beyond the limits, some non-finite, some all zero
            cmd = draws.normal(size=n) * (0.0 if k % 400 == 0 else 0.6)
            if k % 350 == 0:
                cmd[1] = np.nan
            finite = arm.set_command(cmd)
            assert finite == bool(np.isfinite(cmd).all())
            c = np.where(np.isfinite(cmd), cmd, 0.0)
            ref["command"] = np.maximum(np.minimum(c, vmax), -vmax)
            assert np.array_equal(arm.command, ref["command"])
        if k == 1500:
            arm.fault(2, "test")
            ref["healthy"][2] = 0.0
            ref["qdot"][2] = 0.0
        if k == 2500:
            arm.enabled = ref["enabled"] = False
        arm.step(h)
        _reference_arm_step(ref, h, alpha)
        assert np.array_equal(arm.q, ref["q"]) and np.array_equal(arm.qdot, ref["qdot"])
