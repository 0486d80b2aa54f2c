"""Fitting simulator parameters to what a run log measured (pure functions on arrays).

Each function takes plain arrays (times in s, SI units) and returns a
:class:`Fit`: the value(s), their one-sigma uncertainty and how many samples
they rest on. Nothing here reads files; :mod:`mission.calibration.logdata`
extracts the arrays from MCAP logs.

* :func:`fit_velocity_response`: commanded vs measured body velocity of one
  DOF -> the first-order model of :mod:`sim_backend.vehicle_dynamics` (time
  constant, dead band, low-speed gain and scale) by nonlinear least squares on
  the measured samples, covariance from the Jacobian; the residual gives the
  unmodelled disturbance (std and correlation time) once the sensor noise is
  removed.
* :func:`white_noise_std`: std of white sensor noise on a slowly varying signal,
  from second differences of consecutive samples (robust to outliers: MAD).
* :func:`sample_rate`: rate of a sensor from its sample times, and the share of
  samples lost (gaps).
* :func:`detection_rate`: share of camera images with a detection, over the
  ranges where the target was in view, and the farthest range seen (visibility).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares
from scipy.signal import lfilter

#: A robust standard deviation from the median absolute deviation of normal data.
MAD_TO_STD = 1.4826


@dataclass(frozen=True)
class Fit:
    """A fitted value with its one-sigma uncertainty; ``n`` samples used; ``note``
    says what limits it (empty when nothing does)."""

    value: float
    sigma: float
    n: int
    note: str = ""


@dataclass(frozen=True)
class ResponseFit:
    """First-order velocity response of one DOF (:mod:`sim_backend.vehicle_dynamics`)."""

    time_constant_s: Fit
    dead_band: Fit
    low_speed_gain: Fit
    low_speed_scale: Fit
    disturbance_std: Fit
    disturbance_time_s: Fit
    rms_residual: float
    extra: dict = field(default_factory=dict)


def steady_gain(c: np.ndarray, dead_band: float, g0: float, scale: float) -> np.ndarray:
    """The first-order model's steady response to commands ``c`` (its reference):
    zero within the dead band, gain rising from ``g0`` to 1 over ``scale``."""
    mag = np.abs(c)
    gain = 1.0 - (1.0 - g0) * np.exp(-(mag - dead_band) / max(scale, 1e-9))
    return np.where(mag <= dead_band, 0.0, c * gain)


def simulate_response(
    t_cmd: np.ndarray,
    c: np.ndarray,
    t_meas: np.ndarray,
    tau: float,
    dead_band: float,
    g0: float,
    scale: float,
    v0: float = 0.0,
    h: float = 0.01,
) -> np.ndarray:
    """The first-order model's velocity at ``t_meas`` for commands ``c`` held from each
    ``t_cmd`` on (zero-order hold), integrated exactly on a grid of ``h`` s."""
    grid = np.arange(t_cmd[0], max(t_cmd[-1], t_meas[-1]) + h, h)
    idx = np.clip(np.searchsorted(t_cmd, grid, side="right") - 1, 0, len(c) - 1)
    ref = steady_gain(c[idx], dead_band, g0, scale)
    a = math.exp(-h / tau) if tau > 0 else 0.0

    # v[k+1] = a v[k] + (1 - a) ref[k], v[0] = v0
    v, _ = lfilter([0.0, 1.0 - a], [1.0, -a], ref, zi=[v0])  # b0 = 0: v[0] is the state, v0
    return np.interp(t_meas, grid, v)


def white_noise_std(y: np.ndarray) -> Fit:
    """Std of white noise on consecutive samples ``y`` of a slowly varying signal:
    second differences have variance 6 sigma^2 (signal curvature neglected);
    MAD-based, so manoeuvres and outliers weigh little."""
    y = np.asarray(y, dtype=float)
    y = y[np.isfinite(y)]
    if y.size < 8:
        return Fit(math.nan, math.nan, int(y.size), "too few samples")
    d2 = y[2:] - 2.0 * y[1:-1] + y[:-2]
    med = float(np.median(d2))
    s = MAD_TO_STD * float(np.median(np.abs(d2 - med))) / math.sqrt(6.0)
    # the MAD-based std of n normal samples has a relative sd of about 1.1 / sqrt(n)
    return Fit(s, 1.1 * s / math.sqrt(d2.size), int(d2.size))


def sample_rate(times: np.ndarray) -> tuple[Fit, Fit]:
    """``(rate Hz, lost share)`` of a sensor from the times of its distinct samples:
    the period is the median interval; a gap of k periods means k - 1 lost samples."""
    t = np.unique(np.asarray(times, dtype=float))
    t = t[np.isfinite(t)]
    if t.size < 3:
        return Fit(math.nan, math.nan, int(t.size), "too few samples"), Fit(math.nan, math.nan, int(t.size))
    dt = np.diff(t)
    period = float(np.median(dt))
    lost = float(np.sum(np.maximum(np.round(dt / period) - 1.0, 0.0)))
    expected = lost + dt.size
    p = lost / expected
    rate = 1.0 / period
    jitter = float(np.std(dt[np.abs(dt - period) < 0.5 * period])) if dt.size > 1 else 0.0
    return (
        Fit(rate, rate * jitter / period / math.sqrt(dt.size), int(dt.size)),
        Fit(p, math.sqrt(max(p * (1 - p), 1.0 / expected) / expected), int(expected)),
    )


def correlation_time(x: np.ndarray, dt: float) -> float:
    """Lag (s) where the autocorrelation of ``x`` first falls below 1/e (NaN if never)."""
    x = np.asarray(x, dtype=float) - np.mean(x)
    n = x.size
    if n < 8 or not np.any(x):
        return math.nan
    f = np.fft.rfft(x, 2 * n)
    ac = np.fft.irfft(f * np.conj(f))[:n]
    ac /= ac[0]
    below = np.flatnonzero(ac < math.exp(-1.0))
    return float(below[0] * dt) if below.size else math.nan


def fit_velocity_response(
    t_cmd: np.ndarray,
    c: np.ndarray,
    t_meas: np.ndarray,
    y: np.ndarray,
    sensor_noise: float,
    guess: tuple[float, float, float, float] = (0.8, 0.01, 0.6, 0.05),
) -> ResponseFit:
    """Fit the first-order response (tau, dead band, low-speed gain, scale) of one DOF:
    commands ``c`` at ``t_cmd`` (held), measurements ``y`` at ``t_meas``; ``sensor_noise``:
    the measurement's own white noise std (removed from the residual to get the
    disturbance)."""

    t_cmd, c, t_meas, y = (np.asarray(a, dtype=float) for a in (t_cmd, c, t_meas, y))
    ok = np.isfinite(y) & (t_meas >= t_cmd[0])
    t_meas, y = t_meas[ok], y[ok]
    lo = np.array([0.02, 0.0, 0.0, 1e-3])
    hi = np.array([20.0, 0.2, 1.5, 1.0])
    x0 = np.clip(np.array(guess, dtype=float), lo + 1e-6, hi - 1e-6)

    def residual(x: np.ndarray) -> np.ndarray:
        return simulate_response(t_cmd, c, t_meas, x[0], x[1], x[2], x[3], v0=float(y[0])) - y

    sol = least_squares(residual, x0, bounds=(lo, hi), x_scale=np.array([0.5, 0.01, 0.2, 0.03]))
    r = sol.fun
    n, k = r.size, 4
    s2 = float(r @ r) / max(1, n - k)
    try:
        cov = np.linalg.pinv(sol.jac.T @ sol.jac) * s2
        sig = np.sqrt(np.maximum(np.diag(cov), 0.0))
    except np.linalg.LinAlgError:
        sig = np.full(4, math.nan)
    # weakly identified (commands never small enough, or never large enough): say so
    notes = ["" if sig[i] < 0.5 * max(abs(sol.x[i]), 1e-3) else "weakly identified" for i in range(4)]
    dt = float(np.median(np.diff(t_meas))) if t_meas.size > 1 else math.nan
    rms = math.sqrt(float(np.mean(r * r)))
    dist = math.sqrt(max(0.0, rms * rms - sensor_noise * sensor_noise))
    tcorr = correlation_time(r, dt)
    tau, dead_band, gain, scale = (Fit(float(sol.x[i]), float(sig[i]), n, notes[i]) for i in range(4))
    return ResponseFit(
        tau,
        dead_band,
        gain,
        scale,
        disturbance_std=Fit(dist, dist / math.sqrt(max(1, n / 20)), n, "residual minus sensor noise"),
        disturbance_time_s=Fit(
            tcorr,
            tcorr / math.sqrt(max(1.0, float(np.ptp(t_meas)) / max(tcorr, 1e-3))) if math.isfinite(tcorr) else math.nan,
            n,
        ),
        rms_residual=rms,
    )


def detection_rate(
    image_period: float, opportunity_ranges: np.ndarray, detection_ranges: np.ndarray, bin_m: float = 0.5
) -> tuple[Fit, Fit, list[tuple[float, int, int]]]:
    """Detection probability per image and visibility from the camera-to-target ranges
    (m) at every image time when the target was in the field of view
    (``opportunity_ranges``) and at the images with a detection. Returns
    ``(p_detect, visibility_m, per-bin (range_lo, images, detections))``: the
    probability over the ranges up to the farthest detection, the visibility as that
    farthest range (sigma: the bin width when images beyond it saw nothing)."""
    opp = np.asarray(opportunity_ranges, dtype=float)
    det = np.asarray(detection_ranges, dtype=float)
    if det.size == 0:
        return (
            Fit(0.0, math.nan, int(opp.size), "no detection"),
            Fit(math.nan, math.nan, int(opp.size), "no detection"),
            [],
        )
    far = float(np.max(det))
    inside = opp[opp <= far]
    n = max(int(inside.size), int(det.size))
    p = det.size / n
    sigma_p = math.sqrt(max(p * (1.0 - p), 1.0 / n) / n)
    beyond = opp[opp > far]
    vis = Fit(
        far,
        bin_m if beyond.size else math.nan,
        int(det.size),
        "" if beyond.size else "no image beyond it: a lower bound",
    )
    edges = np.arange(0.0, max(float(np.max(opp)) if opp.size else far, far) + bin_m, bin_m)
    bins = []
    for a in edges:
        k_opp = int(np.sum((opp >= a) & (opp < a + bin_m)))
        k_det = int(np.sum((det >= a) & (det < a + bin_m)))
        if k_opp or k_det:
            bins.append((float(a), k_opp, k_det))
    return Fit(p, sigma_p, n, f"{det.size} detections in {n} images (period {image_period:.3g} s)"), vis, bins
