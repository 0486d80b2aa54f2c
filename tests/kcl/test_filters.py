"""First-order low-pass filter of the vehicle velocity feedback."""

import math

import numpy as np
import pytest

from kcl.filters import FirstOrderLowPass


def test_step_response_matches_first_order() -> None:
    f = FirstOrderLowPass(50.0, 2)
    f.update(np.zeros(2), 0.0)
    t = 0.0
    for _ in range(20):  # 20 ms at irregular steps
        t += 0.001
        y = f.update(np.array([1.0, -2.0]), t)
    assert y[0] == pytest.approx(1.0 - math.exp(-50.0 * 0.02), rel=1e-9)
    assert y[1] == pytest.approx(-2.0 * (1.0 - math.exp(-1.0)), rel=1e-9)


def test_first_sample_and_stale_samples() -> None:
    f = FirstOrderLowPass(10.0, 1)
    assert f.value is None
    assert f.update(np.array([3.0]), 1.0)[0] == 3.0
    assert f.update(np.array([100.0]), 1.0)[0] == 3.0  # not newer: ignored
    f.reset()
    assert f.value is None
    with pytest.raises(ValueError):
        FirstOrderLowPass(0.0, 1)


def test_attenuates_noise_above_cutoff() -> None:
    rng = np.random.default_rng(0)
    f = FirstOrderLowPass(50.0, 1)
    out = [f.update(rng.normal(size=1), 0.001 * k)[0] for k in range(4000)]
    assert np.std(out[100:]) < 0.3  # white noise at 1 kHz, cutoff 50 rad/s
