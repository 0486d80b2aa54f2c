"""PNG plots of run logs (matplotlib, Agg backend: no display needed).

One log (:func:`plot_all`):

* ``vehicle_velocity.png`` - commanded vs measured body velocity, one panel per DOF.
* ``joint_velocities.png`` - one panel per joint: reference (the KCL output,
  MARIS figs. 17/18) and measured velocity.
* ``task_activations.png`` - each KCL task's effective activation over time:
  its own activation (max over components) times the action factor a_p, so a
  task of an action being left fades out with the transition and is 0 once
  the action is stopped (an abort), action switches marked.
* ``tool_to_target.png`` - simulator tool-to-target distance (sim logs only).

Several logs (:func:`plot_overlay`, ``maris log plot a.mcap b.mcap``): the same
views with one colour per log (e.g. filtered vs unfiltered velocity feedback,
the comparison of MARIS figs. 17 and 18): vehicle angular rates measured,
joint references per joint, tool-to-target. Titles are wrapped to the figure.
"""

from __future__ import annotations

import textwrap
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from mission.logs.reader import RunLog
from mission.logs.summary import action_timeline

DOF_LABELS = ("u [m/s]", "v [m/s]", "w [m/s]", "p [rad/s]", "q [rad/s]", "r [rad/s]")


def _plt():
    import matplotlib  # plotting only: matplotlib loads when a chart is drawn

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _title(fig, text: str) -> None:
    """A figure title wrapped to the figure's width (about 11 characters per inch at 10 pt)."""
    fig.suptitle(textwrap.fill(text, width=int(fig.get_figwidth() * 11)), fontsize=10)


def _mark_actions(ax, switches: list[tuple[float, str]], label: bool) -> None:
    for t, name in switches:
        ax.axvline(t, color="0.5", lw=0.8, ls=":")
        if label:
            ax.annotate(
                name,
                (t, 1.0),
                xycoords=("data", "axes fraction"),
                rotation=90,
                va="top",
                ha="right",
                fontsize=7,
                color="0.3",
            )


def joint_names(log: RunLog, n: int) -> list[str]:
    config = log.messages("/run/config")
    names = list((config[0].get("joint_names") if config else None) or [])
    return [names[j] if j < len(names) else f"q{j + 1}" for j in range(n)]


def plot_vehicle_velocity(log: RunLog, out: Path) -> Path | None:
    tc, cmd = log.series("/vehicle/command", "body_velocity")
    tm, meas = log.series("/vehicle/navigation", "body_velocity")
    if cmd.size == 0 and meas.size == 0:
        return None
    plt = _plt()
    fig, axes = plt.subplots(6, 1, sharex=True, figsize=(9, 10))
    switches = action_timeline(log)
    for i, ax in enumerate(axes):
        if cmd.ndim == 2 and cmd.shape[1] > i:
            ax.plot(tc, cmd[:, i], lw=1.0, label="commanded")
        if meas.ndim == 2 and meas.shape[1] > i:
            ax.plot(tm, meas[:, i], lw=1.0, ls="--", label="measured")
        ax.set_ylabel(DOF_LABELS[i], fontsize=8)
        ax.grid(alpha=0.3)
        _mark_actions(ax, switches, label=(i == 0))
    axes[0].legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("time [s]")
    _title(fig, "Vehicle body velocity: commanded vs measured (vehicle frame)")
    return _save(fig, out / "vehicle_velocity.png")


def plot_joint_velocities(log: RunLog, out: Path) -> Path | None:
    tc, cmd = log.series("/arm/command", "velocity")
    tm, meas = log.series("/arm/state", "velocity")
    if cmd.ndim != 2 or cmd.size == 0:
        return None
    plt = _plt()
    n = cmd.shape[1]
    names = joint_names(log, n)
    fig, axes = plt.subplots(n, 1, sharex=True, figsize=(9, 1.35 * n + 1.2), squeeze=False)
    switches = action_timeline(log)
    for j in range(n):
        ax = axes[j, 0]
        ax.plot(tc, cmd[:, j], lw=1.0, color="C0", label="reference")
        if meas.ndim == 2 and meas.shape[1] > j:
            ax.plot(tm, meas[:, j], lw=0.8, color="C1", alpha=0.85, label="measured")
        ax.set_ylabel(f"{names[j]}\n[rad/s]", fontsize=7)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
        _mark_actions(ax, switches, label=(j == 0))
    axes[0, 0].legend(loc="upper right", fontsize=7, ncol=2)
    axes[-1, 0].set_xlabel("time [s]")
    _title(fig, "Arm joint velocities: KCL reference and measured, one panel per joint (MARIS figs. 17/18)")
    return _save(fig, out / "joint_velocities.png")


def task_activation_series(log: RunLog) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Times (s) and, per task, its effective activation: max over its components
    times the task's action factor ``a_p`` (1 when the log has none); 0 when the
    task is absent from the telemetry."""
    msgs = log.messages("/kcl")
    t = np.array([m["t"] for m in msgs], dtype=float) - log.t0
    names: list[str] = []
    for m in msgs:
        for name in m.get("tasks") or {}:
            if name not in names:
                names.append(name)
    series = {n: np.zeros(len(msgs)) for n in names}
    for i, m in enumerate(msgs):
        for name, task in (m.get("tasks") or {}).items():
            a = task.get("activation") if isinstance(task, dict) else task
            if isinstance(a, list):
                vals = [x for x in a if x is not None]
                a = max(vals) if vals else 0.0
            ap = task.get("a_p", 1.0) if isinstance(task, dict) else 1.0
            if a is None or ap is None:
                series[name][i] = np.nan
            else:
                series[name][i] = float(a) * float(ap)
    return t, series


def plot_task_activations(log: RunLog, out: Path) -> Path | None:
    t, series = task_activation_series(log)
    if not series:
        return None
    plt = _plt()
    n = len(series)
    fig, axes = plt.subplots(n, 1, sharex=True, figsize=(9, max(3.0, 0.55 * n + 1.5)), squeeze=False)
    switches = action_timeline(log)
    for i, (name, a) in enumerate(series.items()):
        ax = axes[i, 0]
        ax.fill_between(t, 0, a, step="post", alpha=0.35)
        ax.plot(t, a, lw=0.8, drawstyle="steps-post")
        ax.set_ylim(-0.05, 1.1)
        ax.set_yticks([])
        ax.set_ylabel(name, rotation=0, ha="right", va="center", fontsize=7)
        _mark_actions(ax, switches, label=(i == 0))
    axes[-1, 0].set_xlabel("time [s]")
    _title(fig, "Task activations x action factor a_p (0..1), action switches marked")
    return _save(fig, out / "task_activations.png")


def plot_tool_to_target(log: RunLog, out: Path) -> Path | None:
    t, d = log.series("/ground_truth", "tool_to_target_m")
    if d.size == 0 or not np.isfinite(d).any():
        return None
    plt = _plt()
    fig, ax = plt.subplots(figsize=(9, 4))
    ax.plot(t, d, lw=1.2)
    _mark_actions(ax, action_timeline(log), label=True)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("tool to grasp frame [m]")
    ax.grid(alpha=0.3)
    _title(fig, "Tool-to-target distance (simulator ground truth)")
    return _save(fig, out / "tool_to_target.png")


def _save(fig, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=100, bbox_inches="tight")
    _plt().close(fig)
    return path


PLOTS = (plot_vehicle_velocity, plot_joint_velocities, plot_task_activations, plot_tool_to_target)


def plot_all(log: RunLog, out_dir: str | Path) -> tuple[list[Path], list[str]]:
    """Write every plot the log has data for; returns (written files, names skipped for lack of data)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written, skipped = [], []
    for fn in PLOTS:
        p = fn(log, out)
        if p is None:
            skipped.append(fn.__name__.removeprefix("plot_"))
        else:
            written.append(p)
    return written, skipped


# ---------------------------------------------------------------- several logs
def log_labels(logs: Sequence[RunLog]) -> list[str]:
    """Short distinct labels: the file stems (with their folder when stems repeat)."""
    stems = [log.path.stem for log in logs]
    if len(set(stems)) == len(stems):
        return stems
    return [f"{log.path.parent.name}/{log.path.stem}" for log in logs]


def plot_overlay(logs: Sequence[RunLog], out_dir: str | Path) -> tuple[list[Path], list[str]]:
    """Overlay plots of several logs, one colour per log (time from each run's start)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    plt = _plt()
    labels = log_labels(logs)
    written: list[Path] = []
    skipped: list[str] = []
    # vehicle angular rates, measured (the feedback the arm compensates)
    series = [log.series("/vehicle/navigation", "body_velocity") for log in logs]
    if any(v.ndim == 2 and v.size for _, v in series):
        fig, axes = plt.subplots(3, 1, sharex=True, figsize=(9, 6.5))
        for k, ((t, v), label) in enumerate(zip(series, labels)):
            for i, ax in enumerate(axes):
                if v.ndim == 2 and v.shape[1] > 3 + i:
                    ax.plot(t, v[:, 3 + i], lw=0.9, color=f"C{k}", alpha=0.85, label=label)
        for i, ax in enumerate(axes):
            ax.set_ylabel(DOF_LABELS[3 + i], fontsize=8)
            ax.grid(alpha=0.3)
        axes[0].legend(loc="upper right", fontsize=7)
        axes[-1].set_xlabel("time [s]")
        _title(fig, "Vehicle angular rates, measured: " + " vs ".join(labels))
        written.append(_save(fig, out / "overlay_vehicle_rates.png"))
    else:
        skipped.append("overlay_vehicle_rates")
    # joint references, one panel per joint
    series = [log.series("/arm/command", "velocity") for log in logs]
    n = max((v.shape[1] for _, v in series if v.ndim == 2), default=0)
    if n:
        names = joint_names(logs[0], n)
        fig, axes = plt.subplots(n, 1, sharex=True, figsize=(9, 1.35 * n + 1.2), squeeze=False)
        for k, ((t, v), label) in enumerate(zip(series, labels)):
            if v.ndim != 2:
                continue
            for j in range(min(n, v.shape[1])):
                axes[j, 0].plot(t, v[:, j], lw=0.9, color=f"C{k}", alpha=0.85, label=label)
        for j in range(n):
            axes[j, 0].set_ylabel(f"{names[j]}\n[rad/s]", fontsize=7)
            axes[j, 0].tick_params(labelsize=7)
            axes[j, 0].grid(alpha=0.3)
        axes[0, 0].legend(loc="upper right", fontsize=7, ncol=min(3, len(labels)))
        axes[-1, 0].set_xlabel("time [s]")
        _title(fig, "Joint reference velocities (MARIS figs. 17/18): " + " vs ".join(labels))
        written.append(_save(fig, out / "overlay_joint_references.png"))
    else:
        skipped.append("overlay_joint_references")
    series = [log.series("/ground_truth", "tool_to_target_m") for log in logs]
    if any(d.size and np.isfinite(d).any() for _, d in series):
        fig, ax = plt.subplots(figsize=(9, 4))
        for k, ((t, d), label) in enumerate(zip(series, labels)):
            if d.size:
                ax.plot(t, d, lw=1.1, color=f"C{k}", label=label)
        ax.set_xlabel("time [s]")
        ax.set_ylabel("tool to grasp frame [m]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        _title(fig, "Tool-to-target distance (simulator ground truth): " + " vs ".join(labels))
        written.append(_save(fig, out / "overlay_tool_to_target.png"))
    else:
        skipped.append("overlay_tool_to_target")
    return written, skipped
