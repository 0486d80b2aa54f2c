"""``maris log summary|plot|export|tree|recover|replay``: study a run log (MCAP)
after the fact (``tree`` and ``recover`` live in :mod:`mission.commands._log_tools`,
``replay`` in :mod:`mission.commands._log_replay`)."""

from __future__ import annotations

import argparse
import json
import os
import sys

from mission.commands._log_replay import add_parser as add_replay_parser
from mission.commands._log_tools import register_tools

# Imports inside the functions below are deliberate: shell completion (argcomplete) builds
# the parser on every Tab, so a command loads its heavy modules only when it runs.


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "log",
        help="summarize, plot, export or replay a run log (.mcap)",
        description="Study a run log written by `maris sim` or `maris run`.",
    )
    sub = p.add_subparsers(dest="log_command", metavar="ACTION", required=True)
    s = sub.add_parser("summary", help="outcome, duration, actions, grasp, closest approach to limits")
    s.add_argument("log", help="run log (.mcap)")
    s.add_argument("--json", action="store_true", help="print the summary as JSON")
    s.set_defaults(func=_summary)
    pl = sub.add_parser(
        "plot",
        help="PNG plots: vehicle velocity, joint velocities, task activations, tool-to-target; several logs: overlaid",
    )
    pl.add_argument("log", nargs="+", help="run log (.mcap); give several to overlay them in one figure per view")
    pl.add_argument("--out", required=True, help="output directory for the PNG files")
    pl.set_defaults(func=_plot)

    register_tools(sub)
    e = sub.add_parser("export", help="CSV export, one file per topic")
    e.add_argument("log", help="run log (.mcap)")
    e.add_argument("--csv", required=True, metavar="DIR", help="output directory for the CSV files")
    e.add_argument("--topic", action="append", help="only this topic (repeatable), e.g. /vehicle/command")
    e.set_defaults(func=_export)

    add_replay_parser(sub)


def _out(text: str) -> None:
    """Print to stdout; a closed pipe (``maris log summary LOG | head``) is not an error."""
    try:
        print(text, flush=True)
    except BrokenPipeError:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())


def _read(path: str):
    from mission.logs.reader import LogError, read_log

    try:
        log = read_log(path)
    except LogError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return None
    if log.truncated:
        print(f"note: {path} was cut short ({log.stop_reason}); showing what was written", file=sys.stderr)
    return log


def _summary(args: argparse.Namespace) -> int:
    from mission.logs.reader import LogError
    from mission.logs.summary import format_summary, summarize_file

    try:  # streamed: memory does not grow with the log's length
        s, stream = summarize_file(args.log)
    except LogError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if stream.truncated:
        print(f"note: {args.log} was cut short ({stream.stop_reason}); showing what was written", file=sys.stderr)
    _out(json.dumps(s, indent=2) if args.json else format_summary(s))
    return 0


def _plot(args: argparse.Namespace) -> int:
    from mission.logs.plots import plot_all, plot_overlay

    logs = [_read(path) for path in args.log]
    if any(log is None for log in logs):
        return 2
    try:
        written, skipped = plot_all(logs[0], args.out) if len(logs) == 1 else plot_overlay(logs, args.out)
    except OSError as exc:
        print(f"error: cannot write plots to {args.out}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    for p in written:
        _out(str(p))
    if skipped:
        print(f"no data for: {', '.join(skipped)}", file=sys.stderr)
    return 0 if written else 1


def _export(args: argparse.Namespace) -> int:
    from mission.logs.export import export_csv

    log = _read(args.log)
    if log is None:
        return 2
    unknown = [t for t in args.topic or () if t not in log.topics]
    if unknown:
        print(
            f"error: not in {args.log}: {', '.join(unknown)}; topics: {', '.join(sorted(log.topics))}", file=sys.stderr
        )
        return 2
    try:
        written = export_csv(log, args.csv, args.topic)
    except OSError as exc:
        print(f"error: cannot write CSV files to {args.csv}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    for p in written:
        _out(str(p))
    return 0
