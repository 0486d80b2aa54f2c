"""``maris log replay LOG``: run the logged supervisor again on the logged inputs.

Registered by :mod:`mission.commands.log` as an action of ``maris log``. Exit
code: 0 identical (or a what-if that ran), 1 diverged, 2 bad input.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

from mission.commands._runner import log_path_problem
from mission.runtime.progress import ProgressDisplay

# Imports inside the functions below are deliberate: shell completion (argcomplete) builds
# the parser on every Tab, so a command loads its heavy modules only when it runs.

DESCRIPTION = (
    "Rebuild the mission, actions, model and controller from the log's own sources and run the same "
    "supervisor again on the logged inputs (every device reading, health, detection, operator command and "
    "clock reading, at the step it was used). Without --mission/--set: compare every command, device call, "
    "tree status change, action switch and KCL reference with the log and report 'identical' or the first "
    "step, channel and value where they differ (exit code 1). With --mission or --set: an open-loop what-if "
    "(the world does not react), with the differences summarized (and plotted with --plot)."
)


def add_parser(sub: argparse._SubParsersAction) -> None:
    r = sub.add_parser(
        "replay",
        help="replay a run from its log: identical, or where it diverges; what-if runs",
        description=DESCRIPTION,
    )
    r.add_argument("log", help="run log (.mcap) written by `maris sim` or `maris run`")
    r.add_argument("--mission", metavar="FILE", help="what-if: replay the inputs through this mission instead")
    r.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="controller.KEY=VALUE",
        help="what-if: change a controller setting, e.g. controller.filter_cutoff_rad_s=.inf "
        "(keys: filter_cutoff_rad_s, compensation, vehicle_velocity_limit, joint_velocity_limit, lam, "
        "threshold, eta; repeatable)",
    )
    r.add_argument(
        "--tolerance",
        type=float,
        default=0.0,
        metavar="REL",
        help="compare numbers within REL * max(1, |value|) instead of bit for bit (default 0; "
        "1e-9 for a log replayed on another machine, see docs/replay.md)",
    )
    r.add_argument(
        "--out", metavar="PATH", help="keep the replay's own log (.mcap) there, e.g. to open both in Foxglove"
    )
    r.add_argument(
        "--plot", metavar="DIR", help="write PNGs of the logged and replayed references and their differences"
    )
    r.add_argument(
        "--plot-window", metavar="T0:T1", help="plot only from T0 to T1 s (since the run's start), e.g. 28:36"
    )
    r.add_argument("--json", action="store_true", help="print the report as JSON")
    r.add_argument("--quiet", action="store_true", help="no progress line")
    r.set_defaults(func=replay)


def _err(text: str) -> int:
    print(f"error: {text}", file=sys.stderr)
    return 2


def replay(args: argparse.Namespace) -> int:
    from maris_common.yamlsrc import ConfigError

    if not (args.tolerance >= 0.0):
        return _err(f"--tolerance must be >= 0, got {args.tolerance}")
    if args.mission is not None and not Path(args.mission).is_file():
        return _err(f"--mission {args.mission}: no such file")
    if args.out is not None:
        if Path(args.out).resolve() == Path(args.log).resolve():
            return _err("--out must not be the log being replayed")
        problem = log_path_problem(args.out)
        if problem:
            return _err(problem)
    window = None
    if args.plot_window is not None:
        try:
            t0, t1 = (float(x) for x in args.plot_window.split(":"))
        except ValueError:
            return _err(f"--plot-window expects T0:T1 in seconds, got {args.plot_window!r}")
        if not t0 < t1:
            return _err(f"--plot-window: T0 must be before T1, got {args.plot_window!r}")
        window = (t0, t1)
    try:
        from mission.replay.settings import parse_settings

        settings = parse_settings(args.set)
    except ConfigError as exc:
        return _err(f"invalid --set:\n{exc}")

    from mission.logs.reader import LogError
    from mission.replay.report import format_report, report_dict
    from mission.replay.run import replay_log
    from mission.replay.serve import NotReplayable, ReplayStop

    progress = ProgressDisplay(sys.stderr) if not (args.quiet or args.json) and sys.stderr.isatty() else None

    def on_progress(t: float, state: str, action: str | None, leaf: str | None) -> None:
        if progress is not None:
            progress.update(t, state, action, leaf, extra="(replay)")

    try:
        report = replay_log(
            args.log,
            mission=args.mission,
            settings=settings,
            out=args.out,
            tolerance=args.tolerance,
            on_progress=on_progress,
        )
    except LogError as exc:
        return _err(str(exc))
    except (NotReplayable, ReplayStop) as exc:
        return _err(f"cannot replay: {exc}")
    except ConfigError as exc:
        return _err(f"invalid input:\n{exc}")
    finally:
        if progress is not None:
            progress.close()
    try:
        print(json.dumps(report_dict(report), indent=2) if args.json else format_report(report), flush=True)
        if args.plot and report.logs is not None:
            from mission.replay.plots import plot_replay

            try:
                note = f" - what-if: {'; '.join(report.changes)}" if report.whatif else ""
                for p in plot_replay(
                    report.logs.original,
                    report.logs.replay,
                    args.plot,
                    replay_label="what-if" if report.whatif else "replay",
                    note=note,
                    window=window,
                ):
                    print(p, file=sys.stderr if args.json else sys.stdout)
            except OSError as exc:
                return _err(f"cannot write plots to {args.plot}: {exc.strerror or exc}")
    except BrokenPipeError:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    if report.whatif:
        return 0
    return 0 if report.identical else 1
