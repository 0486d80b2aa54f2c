"""How much the arm's joint reference velocities oscillate.

MARIS found that unfiltered angular-rate feedback made the compensating arm
oscillate. Our measure: the RMS, over time and joints, of the joint reference
velocity after a zero-phase 2nd-order Butterworth high-pass at ``cutoff_hz``
(default 1 Hz, far above the grasp approach dynamics and below the arm loop's
Nyquist frequency). The unit is rad/s. Slow, purposeful motion contributes
nothing; jitter that follows sensor noise contributes fully.

Samples must be (near) uniformly spaced; they are resampled to the median step
otherwise.
"""

from __future__ import annotations

import numpy as np


def highpass_rms(t: np.ndarray, qdot: np.ndarray, cutoff_hz: float = 1.0) -> float:
    """High-passed RMS (rad/s) of joint velocities ``qdot`` (k, l) sampled at times ``t`` (k,) s.

    Returns NaN if there are too few samples (under 16) or the sampling rate is
    not above twice the cutoff.
    """
    hp = highpassed(t, qdot, cutoff_hz)
    return float("nan") if hp is None else float(np.sqrt(np.mean(hp * hp)))


def highpassed(t: np.ndarray, qdot: np.ndarray, cutoff_hz: float = 1.0) -> np.ndarray | None:
    """The high-passed samples (on a uniform grid) behind :func:`highpass_rms`, or None."""
    from scipy.signal import butter, sosfiltfilt  # seconds to import: loaded when an oscillation is measured

    t = np.asarray(t, dtype=float)
    q = np.asarray(qdot, dtype=float)
    if q.ndim == 1:
        q = q[:, None]
    if t.ndim != 1 or q.shape[0] != t.shape[0]:
        raise ValueError(f"t has shape {t.shape}, qdot {q.shape}: need (k,) and (k, l)")
    keep = np.isfinite(t) & np.all(np.isfinite(q), axis=1)
    t, q = t[keep], q[keep]
    if t.size < 16:
        return None
    order = np.argsort(t, kind="stable")
    t, q = t[order], q[order]
    dt = float(np.median(np.diff(t)))
    if not dt > 0:
        return None
    fs = 1.0 / dt
    if fs <= 2.0 * cutoff_hz:
        return None
    grid = np.arange(t[0], t[-1] + 0.5 * dt, dt)
    if grid.size != t.size or np.max(np.abs(grid - t)) > 0.25 * dt:
        q = np.column_stack([np.interp(grid, t, q[:, j]) for j in range(q.shape[1])])
    sos = butter(2, cutoff_hz, btype="highpass", fs=fs, output="sos")
    padlen = min(3 * (2 * len(sos) + 1), q.shape[0] - 1)
    return sosfiltfilt(sos, q, axis=0, padlen=padlen)


def segments_rms(segments: list[tuple[np.ndarray, np.ndarray]], cutoff_hz: float = 1.0) -> float:
    """High-passed RMS over several separate stretches ``(t, qdot)`` (each filtered on
    its own, so the jumps between stretches do not count); NaN if none is usable."""
    total, count = 0.0, 0
    for t, q in segments:
        hp = highpassed(t, q, cutoff_hz)
        if hp is not None:
            total += float(np.sum(hp * hp))
            count += hp.size
    return float(np.sqrt(total / count)) if count else float("nan")


def action_segments(
    action_t: np.ndarray, actions: list[str | None], t: np.ndarray, qdot: np.ndarray, action: str
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Split samples ``(t, qdot)`` into the stretches during which ``action`` was active.

    ``action_t`` / ``actions``: times (s, increasing) at which the active action was
    reported; a sample belongs to the latest report at or before its time.
    """
    t = np.asarray(t, dtype=float)
    q = np.asarray(qdot, dtype=float)
    if len(action_t) == 0 or t.size == 0:
        return []
    idx = np.searchsorted(np.asarray(action_t, dtype=float), t, side="right") - 1
    names = np.array([a if a is not None else "" for a in actions], dtype=object)
    active = np.zeros(t.size, dtype=bool)
    ok = idx >= 0
    active[ok] = names[idx[ok]] == action
    edges = np.flatnonzero(np.diff(active.astype(np.int8))) + 1
    out = []
    for chunk in np.split(np.arange(t.size), edges):
        if chunk.size and active[chunk[0]]:
            out.append((t[chunk], q[chunk]))
    return out
