"""Write a :class:`mission.calibration.calibrate.Calibration` as a scenario file and a table.

The scenario ``extends:`` the base and sets only fitted values; each line
carries the uncertainty (one sigma) and sample count in a comment, and DOFs
that were not fitted keep the base value, marked ``not fitted`` with the reason.
"""

from __future__ import annotations

import math
from typing import Any

from mission.calibration.calibrate import DOFS, Calibration
from mission.calibration.fit import Fit
from sim_backend import load_scenario


def _num(x: float) -> str:
    return f"{x:.4g}" if math.isfinite(x) else "nan"


def _pm(f: Fit | None) -> str:
    if f is None:
        return "not fitted"
    s = f"+- {_num(f.sigma)}" if math.isfinite(f.sigma) else "+- ?"
    return f"{s} (n={f.n}{', ' + f.note if f.note else ''})"


def _vec(cal: Calibration, attr: str, base: tuple) -> tuple[list[float], str]:
    vals, notes = [], []
    for i, name in enumerate(DOFS):
        resp = cal.response[i]
        if resp is None:
            vals.append(float(base[i]))
            notes.append(f"{name}: base")
        else:
            f: Fit = getattr(resp, attr)
            vals.append(f.value if math.isfinite(f.value) else float(base[i]))
            notes.append(f"{name}: {_pm(f)}")
    return vals, "; ".join(notes)


def scenario_text(cal: Calibration) -> str:
    """The YAML text of the calibrated scenario."""

    base: dict[str, Any] = dict(load_scenario(cal.base).values)
    d = cal.data
    lines = [f"# Fitted by `maris calibrate` from {len(d.files)} log(s), {d.duration_s:.0f} s of data:"]
    lines += [f"#   {f}" for f in d.files]
    lines += [
        "# Each fitted value carries its one-sigma uncertainty and sample count; `base` = the",
        f"# value of `{cal.base}`, not determined by these logs. Re-run rather than edit by hand.",
        f"extends: {cal.base}",
        f"description: calibrated from {len(d.files)} log(s) ({cal.turbidity} water)",
        "",
    ]
    if any(r is not None for r in cal.response):
        lines += [
            "vehicle:",
            "  model: first_order          # the response a log determines (see maris calibrate --help)",
        ]
        for key, attr in (
            ("time_constant_s", "time_constant_s"),
            ("dead_band", "dead_band"),
            ("low_speed_gain", "low_speed_gain"),
            ("low_speed_scale", "low_speed_scale"),
            ("disturbance_std", "disturbance_std"),
        ):
            vals, note = _vec(cal, attr, base[f"vehicle.{key}"])
            lines.append(f"  {key}: [{', '.join(_num(v) for v in vals)}]")
            lines.append(f"  #   {note}")
        times = [
            r.disturbance_time_s for r in cal.response if r is not None and math.isfinite(r.disturbance_time_s.value)
        ]
        if times:
            t = sorted(f.value for f in times)[len(times) // 2]
            lines.append(f"  disturbance_time_s: {_num(max(t, 0.01))}   # median over the fitted DOFs")
        lines.append("")
    for name, why in cal.skipped.items():
        lines.append(f"# {name}: not fitted: {why}")
    if cal.skipped:
        lines.append("")
    if (
        cal.dvl_rate is not None
        and cal.dvl_noise is not None
        and cal.dvl_loss is not None
        and math.isfinite(cal.dvl_rate.value)
    ):  # the three are fitted together
        lines += [
            "dvl:",
            f"  rate_hz: {_num(cal.dvl_rate.value)}   # {_pm(cal.dvl_rate)}",
            f"  noise_std_mps: {_num(cal.dvl_noise.value)}   # {_pm(cal.dvl_noise)}",
            f"  dropout_probability: {_num(min(1.0, cal.dvl_loss.value))}   # {_pm(cal.dvl_loss)}",
            "",
        ]
    if cal.gyro_noise is not None and math.isfinite(cal.gyro_noise.value):
        lines += [
            "ahrs:",
            f"  rate_noise_std_rad_s: {_num(cal.gyro_noise.value)}   # {_pm(cal.gyro_noise)}; white part "
            "only (a vibration line above half the log rate is aliased)",
            "",
        ]
    if cal.p_detect is not None and math.isfinite(cal.p_detect.value):
        lines += [
            "vision:",
            f"  detection_probability: {{{cal.turbidity}: {_num(cal.p_detect.value)}}}   # {_pm(cal.p_detect)}",
        ]
        if cal.visibility is not None and math.isfinite(cal.visibility.value):
            lines.append(f"  visibility_m: {{{cal.turbidity}: {_num(cal.visibility.value)}}}   # {_pm(cal.visibility)}")
        lines.append("")
    return "\n".join(lines).rstrip("\n") + "\n"


def summary_table(cal: Calibration) -> str:
    """Plain-text table of every fit, for the terminal."""
    out = [f"{'parameter':<34}{'value':>12}  uncertainty"]

    def row(name: str, f: Fit | None) -> None:
        if f is not None:
            out.append(f"{name:<34}{_num(f.value):>12}  {_pm(f)}")

    for i, name in enumerate(DOFS):
        r = cal.response[i]
        if r is None:
            out.append(f"{'response ' + name:<34}{'-':>12}  not fitted: {cal.skipped.get(name, '')}")
            continue
        for attr in (
            "time_constant_s",
            "dead_band",
            "low_speed_gain",
            "low_speed_scale",
            "disturbance_std",
            "disturbance_time_s",
        ):
            row(f"{name}.{attr}", getattr(r, attr))
        out.append(f"{name + '.rms_residual':<34}{_num(r.rms_residual):>12}")
    row("dvl.rate_hz", cal.dvl_rate)
    row("dvl.dropout_probability", cal.dvl_loss)
    row("dvl.noise_std_mps", cal.dvl_noise)
    row("ahrs.rate_noise_std_rad_s", cal.gyro_noise)
    row(f"vision.detection_probability.{cal.turbidity}", cal.p_detect)
    row(f"vision.visibility_m.{cal.turbidity}", cal.visibility)
    if cal.detection_bins:
        out.append(
            "detections by camera range (m): "
            + ", ".join(f"{lo:.1f}-{lo + 0.5:.1f}: {k}/{n}" for lo, n, k in cal.detection_bins)
        )
    return "\n".join(out)
