"""High-passed RMS of joint reference velocities."""

import numpy as np
import pytest

from mission.campaign.oscillation import highpass_rms


def _t(n=2000, fs=100.0):
    return np.arange(n) / fs


def test_slow_motion_scores_near_zero():
    t = _t()
    q = np.column_stack([0.2 * np.sin(2 * np.pi * 0.1 * t), 0.1 * np.cos(2 * np.pi * 0.05 * t)])
    assert highpass_rms(t, q) < 0.005


def test_jitter_scores_its_amplitude():
    t = _t()
    rng = np.random.default_rng(1)
    noise = 0.05 * rng.standard_normal((t.size, 3))
    slow = 0.3 * np.sin(2 * np.pi * 0.1 * t)[:, None]
    score = highpass_rms(t, slow + noise)
    # white noise up to 50 Hz: ~98 % of its power lies above 1 Hz
    assert score == pytest.approx(0.05 * np.sqrt(0.98), rel=0.08)
    tone = highpass_rms(t, 0.1 * np.sin(2 * np.pi * 5.0 * t))
    assert tone == pytest.approx(0.1 / np.sqrt(2), rel=0.03)


def test_uneven_sampling_and_short_input():
    t = _t()
    rng = np.random.default_rng(2)
    t_uneven = t + rng.uniform(-0.003, 0.003, t.size)
    q = 0.1 * np.sin(2 * np.pi * 5.0 * t_uneven)
    assert highpass_rms(t_uneven, q) == pytest.approx(0.1 / np.sqrt(2), rel=0.05)
    assert np.isnan(highpass_rms(t[:10], q[:10]))
    assert np.isnan(highpass_rms(np.arange(100) * 1.0, np.zeros(100)))  # 1 Hz sampling, 1 Hz cutoff
    with pytest.raises(ValueError):
        highpass_rms(t, np.zeros((5, 2)))


def test_action_segments_and_segment_rms():
    from mission.campaign.oscillation import action_segments, segments_rms

    t = _t(3000)
    q = np.zeros((t.size, 2))
    grasp1 = (t >= 5) & (t < 12)
    grasp2 = t >= 20
    q[grasp1 | grasp2] = 0.1 * np.sin(2 * np.pi * 4.0 * t[grasp1 | grasp2])[:, None]
    q[~(grasp1 | grasp2)] = 3.0  # big constant offset outside the grasp: must not count
    segs = action_segments(np.array([0.0, 5.0, 12.0, 20.0]), ["survey", "grasp", "hold", "grasp"], t, q, "grasp")
    assert [len(s[0]) for s in segs] == [700, 1000]
    assert segments_rms(segs) == pytest.approx(0.1 / np.sqrt(2), rel=0.03)
    assert action_segments(np.array([0.0]), ["survey"], t, q, "grasp") == []
    assert np.isnan(segments_rms([]))
