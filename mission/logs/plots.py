"""PNG plots of a run log (matplotlib, Agg backend: no display needed).

* ``vehicle_velocity.png`` - commanded vs measured body velocity, one panel per DOF.
* ``joint_velocities.png`` - joint reference velocities (MARIS figs. 17/18 view),
  measured joint velocities dashed.
* ``task_activations.png`` - each KCL task's activation over time (max over its
  components), action switches marked.
* ``tool_to_target.png`` - simulator tool-to-target distance (sim logs only).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mission.logs.reader import RunLog
from mission.logs.summary import action_timeline

DOF_LABELS = ("u [m/s]", "v [m/s]", "w [m/s]", "p [rad/s]", "q [rad/s]", "r [rad/s]")


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _mark_actions(ax, switches: list[tuple[float, str]], label: bool) -> None:
    for t, name in switches:
        ax.axvline(t, color="0.5", lw=0.8, ls=":")
        if label:
            ax.annotate(name, (t, 1.0), xycoords=("data", "axes fraction"), rotation=90,
                        va="top", ha="right", fontsize=7, color="0.3")


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
    fig.suptitle("Vehicle body velocity: commanded vs measured (vehicle frame)")
    return _save(fig, out / "vehicle_velocity.png")


def plot_joint_velocities(log: RunLog, out: Path) -> Path | None:
    tc, cmd = log.series("/arm/command", "velocity")
    tm, meas = log.series("/arm/state", "velocity")
    if cmd.ndim != 2 or cmd.size == 0:
        return None
    plt = _plt()
    fig, ax = plt.subplots(figsize=(9, 5))
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    config = log.messages("/run/config")
    names = (config[0].get("joint_names") if config else None) or []
    for j in range(cmd.shape[1]):
        c = colors[j % len(colors)]
        ax.plot(tc, cmd[:, j], color=c, lw=1.0, label=names[j] if j < len(names) else f"q{j + 1}")
        if meas.ndim == 2 and meas.shape[1] > j:
            ax.plot(tm, meas[:, j], color=c, lw=0.7, ls="--", alpha=0.7)
    _mark_actions(ax, action_timeline(log), label=True)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("joint velocity [rad/s]")
    ax.grid(alpha=0.3)
    ax.legend(loc="upper right", fontsize=7, ncol=2)
    ax.set_title("Arm joint reference velocities (solid) and measured (dashed)")
    return _save(fig, out / "joint_velocities.png")


def task_activation_series(log: RunLog) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Times (s) and, per task, its activation (max over components; 0 when absent)."""
    msgs = log.messages("/kcl")
    t = np.array([m["t"] for m in msgs], dtype=float) - log.t0
    names: list[str] = []
    for m in msgs:
        for name in (m.get("tasks") or {}):
            if name not in names:
                names.append(name)
    series = {n: np.zeros(len(msgs)) for n in names}
    for i, m in enumerate(msgs):
        for name, task in (m.get("tasks") or {}).items():
            a = task.get("activation") if isinstance(task, dict) else task
            if isinstance(a, list):
                vals = [x for x in a if x is not None]
                a = max(vals) if vals else 0.0
            series[name][i] = float(a) if a is not None else np.nan
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
    fig.suptitle("Task activations (0..1) with action switches")
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
    ax.set_title("Tool-to-target distance (simulator ground truth)")
    return _save(fig, out / "tool_to_target.png")


def _save(fig, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    import matplotlib.pyplot as plt

    plt.close(fig)
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
