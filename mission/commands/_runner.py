"""Shared terminal front end of ``maris sim`` and ``maris run``: progress line,
operator keys and signals, events, final summary, exit code."""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from mission.commands._common import OUTCOME_STYLE, not_found_hint, paint, print_issues, print_json, resolve_mission
from mission.runtime.options import NO_FILTER_CUTOFF_RAD_S, RunHooks, RunOptions, RunTarget
from mission.runtime.progress import ProgressDisplay
from mission.runtime.pylog import BriefFilter

if TYPE_CHECKING:  # the run's modules are imported when a run starts: shell completion stays light
    from mission.runtime.context import Event
    from mission.runtime.result import RunResult
    from mission.runtime.supervisor import Supervisor

# Imports inside the functions below are deliberate: shell completion (argcomplete) builds
# the parser on every Tab, so a command loads its heavy modules only when it runs.

#: Info-level events worth a line on the terminal (warnings and faults always are).
SHOWN_INFO_KINDS = (
    "mission_log",
    "mission",
    "operator",
    "action_start",
    "sim",
    "control",
    "teleop_mode",
    "teleop_limited",
)


def add_run_options(p: argparse.ArgumentParser) -> None:
    """Options shared by ``maris sim`` and ``maris run``: log, KCL compensation, display."""
    p.add_argument("--log", default=None, metavar="PATH", help="log file (default runs/<mission>-<timestamp>.mcap)")
    p.add_argument("--no-compensation", action="store_true", help="arm does not compensate measured vehicle velocity")
    p.add_argument(
        "--filter-cutoff",
        type=filter_cutoff,
        default=50.0,
        metavar="W",
        help="cut-off of the measured-velocity filter, rad/s (default 50, as MARIS); "
        "`off` = no filter (the paper's configuration b)",
    )
    p.add_argument(
        "--log-hz",
        type=float,
        default=20.0,
        metavar="HZ",
        help="rate of device readings and commands in the log (default 20; the arm rate at most)",
    )
    p.add_argument(
        "--gc",
        choices=("auto", "freeze", "manual"),
        default="auto",
        help="garbage collector during the loop: auto (Python's own, default), freeze (objects from "
        "loading are never scanned again), manual (no automatic collection; the young generation "
        "at every tree tick). See docs/performance.md",
    )
    p.add_argument("--quiet", action="store_true", help="no progress line, only the final summary")
    p.add_argument(
        "--json", action="store_true", help="print the result as one JSON document on stdout (implies --quiet)"
    )
    p.add_argument(
        "--strict", action="store_true", help="refuse a mission with safety-lint warnings (see maris validate)"
    )
    p.add_argument(
        "--live",
        nargs="?",
        type=int,
        const=8765,
        default=None,
        metavar="PORT",
        help="serve the log channels to Foxglove at ws://127.0.0.1:PORT while running (default port 8765); "
        "Foxglove's Publish panel (or the /operator/* services) can pause, resume, abort. "
        "With `maris sim`, add --realtime to watch at the pace of the clock",
    )
    p.add_argument(
        "--live-host",
        default="127.0.0.1",
        metavar="ADDR",
        help="address --live binds to (default 127.0.0.1, this machine only); any other needs --live-token",
    )
    p.add_argument(
        "--live-token",
        default=os.environ.get("MARIS_LIVE_TOKEN"),
        metavar="TOKEN",
        help="access token Foxglove clients must give (ws://HOST:PORT/?token=TOKEN); default $MARIS_LIVE_TOKEN",
    )


#: Words meaning "no velocity filter" for ``--filter-cutoff``.
NO_FILTER_WORDS = ("off", "none", "inf", "infinity")


def filter_cutoff(text: str) -> float:
    """``--filter-cutoff`` value: a positive finite number (rad/s), or ``off``
    (also ``none``, ``inf``) for no filter, returned as ``math.inf``."""
    word = text.strip().lower()
    if word in NO_FILTER_WORDS or word in ("+inf", ".inf"):
        return math.inf
    try:
        value = float(word)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a cut-off in rad/s or `off`, got {text!r}") from None
    return value  # range checked by bad_filter_cutoff (a clear message, exit code 2)


def controller_cutoff(value: float) -> float:
    """The KCL's cut-off for a ``--filter-cutoff`` value: ``inf`` (off) becomes the
    no-filter cut-off (a gain of exactly 1 per step, see
    :data:`mission.runtime.options.NO_FILTER_CUTOFF_RAD_S`)."""
    return NO_FILTER_CUTOFF_RAD_S if math.isinf(value) else value


def bad_filter_cutoff(args: argparse.Namespace) -> bool:
    """True (after printing why) when ``--filter-cutoff`` is not usable; maps ``off``
    to the controller's no-filter value."""
    if not (args.filter_cutoff > 0):  # also NaN
        print(
            f"error: --filter-cutoff must be positive, got {args.filter_cutoff:g} (use `off` for no filter)",
            file=sys.stderr,
        )
        return True
    args.filter_cutoff = controller_cutoff(args.filter_cutoff)
    return False


def log_path_problem(path: str | os.PathLike) -> str | None:
    """Why the run log cannot be written at ``path`` (creating its folder), or None."""
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


def execute(
    args: argparse.Namespace,
    target: RunTarget,
    options: RunOptions,
    on_supervisor: Callable[[Supervisor], None] | None = None,
) -> int:
    """Run ``target`` (its mission: ``args.mission``) with :func:`mission.runtime.api.run_mission`
    as ``options`` and the command line say; 0 only on success."""
    # the run's modules, imported when a run starts (module top: shell completion stays light)
    import mission.replay.record  # noqa: F401 - registers the input record of the run's log
    from maris_common.yamlsrc import ConfigError
    from mission.runtime.api import default_log_path, run_mission
    from mission.runtime.operator import KEY_HELP, TELEOP_KEY_HELP, CommandQueue, KeyReader, SignalAbort
    from mission.runtime.report import format_result
    from mission.runtime.requests import Poller
    from mission.runtime.supervisor import SupervisorOptions

    args.mission = resolve_mission(args.mission)
    target = dataclasses.replace(target, mission=args.mission)
    as_json = getattr(args, "json", False)
    log_hz = getattr(args, "log_hz", 20.0)
    if not (log_hz > 0):
        print(f"error: --log-hz must be positive, got {log_hz}", file=sys.stderr)
        return 2
    supervisor = SupervisorOptions(
        device_log_hz=log_hz,
        reset_faults=getattr(args, "reset_faults", False),
        allow_missing=tuple(getattr(args, "allow_missing", None) or ()),
        gc_mode=getattr(args, "gc", "auto"),
        process=getattr(args, "process_applied", None),
    )
    log_path = None if getattr(args, "no_log", False) else (args.log or default_log_path(args.mission))
    problem = log_path_problem(log_path) if log_path is not None else None
    if problem:
        print(f"error: {problem}", file=sys.stderr)
        return 2
    queue = CommandQueue()
    live = None
    if getattr(args, "live", None) is not None:
        if log_path is None:
            print("error: --live serves the log channels: it cannot be combined with --no-log", file=sys.stderr)
            return 2
        from mission.logs.live import LiveServer

        host = getattr(args, "live_host", "127.0.0.1")
        try:
            live = LiveServer(args.live, host=host, token=getattr(args, "live_token", None), commands=queue)
        except (OSError, RuntimeError, ValueError) as exc:
            print(f"error: cannot serve Foxglove on {host}:{args.live}: {exc}", file=sys.stderr)
            return 2
    quiet = getattr(args, "quiet", False) or as_json
    progress = ProgressDisplay(sys.stdout)
    signals = SignalAbort(queue)
    keys: KeyReader | None = None
    pollers: list[Poller] = []
    if sys.stdin.isatty() and not quiet:
        try:
            reader = keys = KeyReader(queue)
            pollers.append(lambda _t: reader.poll())
        except Exception:  # noqa: BLE001 - no key control on odd terminals, signals still work
            keys = None

    display = {"on": not quiet}
    library = BriefFilter()  # library/driver log lines: each distinct one once on the terminal (all in the log)

    def on_event(ev: Event) -> None:
        if ev.kind == "python_log" and not library.first(ev.message):
            return
        if ev.kind == "control" and ev.fields.get("who") == "operator" and keys is not None and display["on"]:
            progress.message(TELEOP_KEY_HELP)  # the operator has control: how to drive from here
        if display["on"] and ev.kind != "live" and (ev.level != "info" or ev.kind in SHOWN_INFO_KINDS):
            try:
                level = paint(
                    f"{ev.level:<7}", {"warning": "yellow", "fault": "bold red"}.get(ev.level, ""), progress.stream
                )
                progress.message(f"[{ev.t:8.2f} s] {level} {ev.kind}: {ev.message}")
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

    feeds = []
    if keys is not None:
        progress.message(KEY_HELP)
        key_reader = keys
        feeds.append(lambda inputs: key_reader.attach_input(inputs.get("keyboard")))
    if live is not None:
        progress.message(f"Foxglove live view: open connection {live.url}")
    try:
        result = run_mission(
            target,
            dataclasses.replace(
                options, log_path=log_path, strict=getattr(args, "strict", False), supervisor=supervisor
            ),
            RunHooks(
                on_progress=on_progress,
                on_event=on_event,
                on_supervisor=on_supervisor,
                commands=queue,
                pollers=pollers,
                live=live,
                input_feeds=feeds,
            ),
        )
    except ConfigError as exc:
        progress.close()
        if as_json:
            print_json({"outcome": None, "error": "invalid input", "errors": [i.to_dict() for i in exc.issues]})
        print("error: invalid input:", file=sys.stderr)
        print_issues(exc.issues)
        hint = not_found_hint(args.mission) if exc.issues and exc.issues[0].mark.file == args.mission else ""
        if hint:
            print(hint, file=sys.stderr)
        return 2
    finally:
        signals.close()
        if keys is not None:
            keys.close()
        if live is not None:
            live.close()
    try:
        progress.close()
        if library.repeats and not as_json:
            print(f"({library.repeats} repeated library warning(s) not shown; all are in the log)", flush=True)
        if as_json:
            print_json(result_json(result))
        else:
            text = format_result(result)
            first, _, rest = text.partition("\n")
            word = result.outcome
            first = first.replace(word, paint(word, OUTCOME_STYLE.get(word, "bold")), 1)
            print(first + ("\n" + rest if rest else ""), flush=True)
    except BrokenPipeError:  # e.g. `maris sim ... | head`: the exit code still tells
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    return 0 if result.succeeded else 1


def result_json(result: RunResult) -> dict[str, Any]:
    """The ``--json`` document of a run: the run summary (outcome, cause,
    actions, closest approach to each limit, faults, warnings) and the metrics."""
    from mission.runtime.report import result_summary  # imported with the run (see execute)

    out = result_summary(result)
    out["log_path"] = None if result.log_path is None else str(result.log_path)
    out["succeeded"] = result.succeeded
    return out
