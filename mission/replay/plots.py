"""PNG plots of a replay against the original log (matplotlib, Agg backend).

* ``replay_joint_references.png``: every arm step's joint reference velocities
  (rad/s), logged and replayed, one panel per joint.
* ``replay_vehicle_references.png``: the vehicle body velocity references
  ``[u v w p q r]`` (m/s, rad/s, vehicle frame), logged and replayed.
* ``replay_reference_differences.png``: replayed minus logged, joints and vehicle.

Times are seconds since the first step; dotted lines mark the actions started
in the log.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from mission.replay.schema import record_steps
from mission.replay.whatif import ARM_CALL, VEHICLE_CALL, command_series

DOF_LABELS = ("u [m/s]", "v [m/s]", "w [m/s]", "p [rad/s]", "q [rad/s]", "r [rad/s]")


def _plt():
    import matplotlib  # plotting only: matplotlib loads when a chart is drawn

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _actions(log: Any) -> list[tuple[float, str]]:
    steps = record_steps(log)
    t0 = float(steps[0]["t"]) if steps else 0.0
    return [
        (float(m["t"]) - t0, str(m.get("message", "")).removeprefix("action ").removesuffix(" started"))
        for m in log.messages("/events")
        if m.get("kind") == "action_start"
    ]


def _mark(ax: Any, switches: list[tuple[float, str]], label: bool) -> None:
    for t, name in switches:
        ax.axvline(t, color="0.6", lw=0.8, ls=":")
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


def _window(t: np.ndarray, x: np.ndarray, window: tuple[float, float] | None) -> tuple[np.ndarray, np.ndarray]:
    if window is None or not len(t):
        return t, x
    keep = (t >= window[0]) & (t <= window[1])
    return t[keep], x[keep]


def _panels(
    plt: Any,
    title: str,
    labels: list[str],
    ta: np.ndarray,
    a: np.ndarray,
    tb: np.ndarray,
    b: np.ndarray,
    names: tuple[str, str],
    switches: list[tuple[float, str]],
    path: Path,
    window: tuple[float, float] | None,
) -> Path:
    ta, a = _window(ta, a, window)
    tb, b = _window(tb, b, window)
    if window is not None:
        switches = [(t, n) for t, n in switches if window[0] <= t <= window[1]]
    fig, axes = plt.subplots(len(labels), 1, sharex=True, figsize=(10, 1.5 * len(labels) + 1.2), squeeze=False)
    for i, ax in enumerate(axes[:, 0]):
        if b.ndim == 2 and b.shape[1] > i:  # behind: the logged line stays visible where they differ
            ax.plot(tb, b[:, i], lw=1.0, color="tab:orange", alpha=0.8, label=names[1])
        if a.ndim == 2 and a.shape[1] > i:
            ax.plot(ta, a[:, i], lw=0.8, color="tab:blue", label=names[0])
        ax.set_ylabel(labels[i], fontsize=8)
        ax.grid(alpha=0.3)
        _mark(ax, switches, label=(i == 0))
    handles, texts = axes[0, 0].get_legend_handles_labels()
    axes[0, 0].legend(handles[::-1], texts[::-1], loc="upper right", fontsize=8)
    axes[-1, 0].set_xlabel("time [s]")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_replay(
    orig: Any,
    replay: Any,
    out_dir: str | Path,
    *,
    replay_label: str = "replay",
    note: str = "",
    window: tuple[float, float] | None = None,
) -> list[Path]:
    """Write the PNGs into ``out_dir`` (created); returns their paths. ``note``: added
    to the titles (e.g. the what-if's change); ``window``: (t0, t1) s to plot."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    plt = _plt()
    switches = _actions(orig)
    header = (orig.messages("/replay/header") or [{}])[0]
    joints = list(header.get("joint_names", ()))
    names = ("logged", replay_label)
    written = []
    ta, qa = command_series(orig, ARM_CALL)
    tb, qb = command_series(replay, ARM_CALL)
    jl = (
        [f"{n} [rad/s]" for n in joints]
        if len(joints) == qa.shape[1]
        else [f"joint {i + 1} [rad/s]" for i in range(qa.shape[1])]
    )
    if qa.size:
        written.append(
            _panels(
                plt,
                "Joint reference velocities (every arm step)" + note,
                jl,
                ta,
                qa,
                tb,
                qb,
                names,
                switches,
                out / "replay_joint_references.png",
                window,
            )
        )
    tva, va = command_series(orig, VEHICLE_CALL)
    tvb, vb = command_series(replay, VEHICLE_CALL)
    if va.size:
        written.append(
            _panels(
                plt,
                "Vehicle velocity references (vehicle frame)" + note,
                list(DOF_LABELS),
                tva,
                va,
                tvb,
                vb,
                names,
                switches,
                out / "replay_vehicle_references.png",
                window,
            )
        )
    n, m = min(len(qa), len(qb)), min(len(va), len(vb))
    if (n and qa.shape[1] == qb.shape[1]) or (m and va.shape[1] == vb.shape[1]):
        fig, axes = plt.subplots(2, 1, sharex=True, figsize=(10, 6))
        if n and qa.shape[1] == qb.shape[1]:
            for i in range(qa.shape[1]):
                axes[0].plot(ta[:n], qb[:n, i] - qa[:n, i], lw=0.9, label=jl[i].split(" [")[0])
            axes[0].legend(fontsize=7, ncol=4, loc="upper right")
        axes[0].set_ylabel(f"joints, {replay_label} - logged [rad/s]", fontsize=8)
        if m and va.shape[1] == vb.shape[1]:
            for i in range(va.shape[1]):
                axes[1].plot(tva[:m], vb[:m, i] - va[:m, i], lw=0.9, label=DOF_LABELS[i].split(" ")[0])
            axes[1].legend(fontsize=7, ncol=6, loc="upper right")
        axes[1].set_ylabel(f"vehicle, {replay_label} - logged", fontsize=8)
        axes[1].set_xlabel("time [s]")
        for ax in axes:
            ax.grid(alpha=0.3)
            _mark(ax, switches, label=False)
            if window is not None:
                ax.set_xlim(*window)
        fig.suptitle("Reference differences" + note)
        fig.tight_layout()
        path = out / "replay_reference_differences.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        written.append(path)
    return written
