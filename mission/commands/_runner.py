"""Shared terminal front end of ``maris sim`` and ``maris run``: progress line,
operator keys and signals, events, final summary, exit code."""

from __future__ import annotations

import argparse
import os
import sys
from typing import Any


#: Info-level events worth a line on the terminal (warnings and faults always are).
SHOWN_INFO_KINDS = ("mission_log", "mission", "operator", "action_start", "sim")


def add_run_options(p: argparse.ArgumentParser) -> None:
    """Options shared by ``maris sim`` and ``maris run``: log, KCL compensation, display."""
    p.add_argument("--log", default=None, metavar="PATH", help="log file (default runs/<mission>-<timestamp>.mcap)")
    p.add_argument("--no-compensation", action="store_true", help="arm does not compensate measured vehicle velocity")
    p.add_argument("--filter-cutoff", type=float, default=50.0, metavar="W",
                   help="cut-off of the angular-rate filter, rad/s (default 50)")
    p.add_argument("--log-hz", type=float, default=20.0, metavar="HZ",
                   help="rate of device readings and commands in the log (default 20; the arm rate at most)")
    p.add_argument("--quiet", action="store_true", help="no progress line, only the final summary")
    p.add_argument("--live", nargs="?", type=int, const=8765, default=None, metavar="PORT",
                   help="serve the log channels to Foxglove at ws://127.0.0.1:PORT while running (default port 8765)")


def bad_filter_cutoff(args: argparse.Namespace) -> bool:
    """True (after printing why) when ``--filter-cutoff`` is not a positive number."""
    if args.filter_cutoff > 0:
        return False
    print(f"error: --filter-cutoff must be positive, got {args.filter_cutoff}", file=sys.stderr)
    return True


def log_path_problem(path: str | os.PathLike) -> str | None:
    """Why the run log cannot be written at ``path`` (creating its folder), or None."""
    from pathlib import Path

    p = Path(path)
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        return f"cannot create the log folder {p.parent}: {exc.strerror or exc}"
    if p.is_dir():
        return f"--log {p} is a folder; give a file path, e.g. {p / 'run.mcap'}"
    if not os.access(p.parent, os.W_OK):
        return f"cannot write the log in {p.parent}: permission denied"
    return None


def execute(args: argparse.Namespace, **run_kwargs: Any) -> int:
    """Run ``args.mission`` with :func:`mission.runtime.api.run_mission`; 0 only on success."""
    from maris_common.yamlsrc import ConfigError
    from mission.runtime.api import default_log_path, run_mission
    from mission.runtime.operator import KEY_HELP, CommandQueue, KeyReader, SignalAbort
    from mission.runtime.progress import ProgressDisplay
    from mission.runtime.report import format_result

    from mission.runtime.supervisor import SupervisorOptions

    log_hz = getattr(args, "log_hz", 20.0)
    if not (log_hz > 0):
        print(f"error: --log-hz must be positive, got {log_hz}", file=sys.stderr)
        return 2
    run_kwargs.setdefault("options", SupervisorOptions(device_log_hz=log_hz, reset_faults=getattr(args, "reset_faults", False)))
    log_path = None if getattr(args, "no_log", False) else (args.log or default_log_path(args.mission))
    problem = log_path_problem(log_path) if log_path is not None else None
    if problem:
        print(f"error: {problem}", file=sys.stderr)
        return 2
    live = None
    if getattr(args, "live", None) is not None:
        if log_path is None:
            print("error: --live serves the log channels: it cannot be combined with --no-log", file=sys.stderr)
            return 2
        from mission.logs.live import LiveServer

        try:
            live = LiveServer(args.live)
        except (OSError, RuntimeError) as exc:
            print(f"error: cannot serve Foxglove on 127.0.0.1:{args.live}: {exc}", file=sys.stderr)
            return 2
    quiet = getattr(args, "quiet", False)
    progress = ProgressDisplay(sys.stdout)
    queue = CommandQueue()
    signals = SignalAbort(queue)
    keys = None
    pollers = []
    if sys.stdin.isatty() and not quiet:
        try:
            keys = KeyReader(queue)
            pollers.append(lambda _t: keys.poll())
        except Exception:  # noqa: BLE001 - no key control on odd terminals, signals still work
            keys = None

    display = {"on": not quiet}
    from mission.runtime.pylog import BriefFilter

    library = BriefFilter()  # library/driver log lines: each distinct one once on the terminal (all in the log)

    def on_event(ev) -> None:
        if ev.kind == "python_log" and not library.first(ev.message):
            return
        if display["on"] and (ev.level != "info" or ev.kind in SHOWN_INFO_KINDS):
            try:
                progress.message(f"[{ev.t:8.2f} s] {ev.level:<7} {ev.kind}: {ev.message}")
                if ev.kind == "internal_error" and "traceback" in ev.fields:
                    progress.message(ev.fields["traceback"].rstrip())
            except OSError:  # terminal or pipe gone: the run (and its log) goes on
                display["on"] = False

    def on_progress(t: float, state: str, action: str | None, leaf: str | None) -> None:
        if display["on"]:
            try:
                progress.update(t, state, action, leaf)
            except OSError:
                display["on"] = False

    if keys is not None:
        progress.message(KEY_HELP)
    if live is not None:
        progress.message(f"Foxglove live view: open connection {live.url}")
    try:
        result = run_mission(args.mission, log_path=log_path, commands=queue, pollers=pollers,
                             on_progress=on_progress, on_event=on_event, live=live, **run_kwargs)
    except ConfigError as exc:
        progress.close()
        print(f"error: invalid input:\n{exc}", file=sys.stderr)
        return 2
    finally:
        signals.close()
        if keys is not None:
            keys.close()
        if live is not None:
            live.close()
    try:
        progress.close()
        if library.repeats:
            print(f"({library.repeats} repeated library warning(s) not shown; all are in the log)", flush=True)
        print(format_result(result), flush=True)
    except BrokenPipeError:  # e.g. `maris sim ... | head`: the exit code still tells
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    return 0 if result.succeeded else 1
