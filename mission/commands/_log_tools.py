"""``maris log tree`` (the behaviour tree at a time, or stepped through its
changes) and ``maris log recover`` (a log cut short made whole again)."""

from __future__ import annotations

import argparse
import sys
import termios
import tty
from pathlib import Path

# Imports inside the functions below are deliberate: shell completion (argcomplete) builds
# the parser on every Tab, so a command loads its heavy modules only when it runs.


def register_tools(sub: argparse._SubParsersAction) -> None:
    t = sub.add_parser(
        "tree",
        help="the behaviour tree at a time (--at T) or stepped change by change (--step)",
        description="Show the behaviour tree recorded in a run log, in py_trees' display style "
        "(status: ✓ success, ✕ failure, * running, - not ticked).",
    )
    t.add_argument("log", help="run log (.mcap)")
    g = t.add_mutually_exclusive_group()
    g.add_argument("--at", type=float, metavar="T", help="seconds since the run start (default: the end)")
    g.add_argument(
        "--step",
        action="store_true",
        help="step through every change: Enter/n next, p previous, q quit (on a terminal); "
        "otherwise print every snapshot",
    )
    t.add_argument("--no-colour", "--no-color", dest="colour", action="store_false", help="no ANSI colours")
    t.set_defaults(func=_tree)
    r = sub.add_parser(
        "recover",
        help="rewrite a log cut short (kill -9, power loss) as a complete, indexed MCAP",
        description="Copy every complete record of LOG into OUT with a fresh summary and index, so "
        "Foxglove and the mcap package's seeking reader open it. The part after the cut is lost.",
    )
    r.add_argument("log", help="the damaged run log (.mcap)")
    r.add_argument("-o", "--out", help="output file (default: LOG with .recovered.mcap)")
    r.set_defaults(func=_recover)


def _colour(args: argparse.Namespace) -> bool:
    return bool(args.colour) and sys.stdout.isatty()


def _tree(args: argparse.Namespace) -> int:
    from mission.commands.log import _out, _read
    from mission.logs.treeview import describe, render_lines, snapshot_at

    log = _read(args.log)
    if log is None:
        return 2
    snaps = log.messages("/tree")
    if not snaps:
        print(f"error: {args.log} has no behaviour tree snapshots (/tree)", file=sys.stderr)
        return 1
    colour = _colour(args)
    t0 = log.t0

    def show(snap: dict) -> str:
        return "\n".join([describe(snap, t0), *render_lines(snap.get("nodes") or [], colour=colour)])

    if not args.step:
        at = log.end_time if args.at is None else args.at
        snap = snapshot_at(snaps, t0 + at)
        if snap is None:
            print(f"error: no tree before t={at:g} s (first at {snaps[0]['t'] - t0:.2f} s)", file=sys.stderr)
            return 1
        _out(show(snap))
        return 0
    if not sys.stdin.isatty() or not sys.stdout.isatty():
        _out("\n\n".join(show(s) for s in snaps))
        return 0
    return _stepper(snaps, show)


def _stepper(snaps: list[dict], show) -> int:
    """Interactive: one snapshot at a time (Enter/n/space next, p/b previous, g first, G last, q quit)."""

    fd = sys.stdin.fileno()
    saved = termios.tcgetattr(fd)
    i = 0
    try:
        tty.setcbreak(fd)
        while True:
            sys.stdout.write(
                "\x1b[2J\x1b[H"
                + show(snaps[i])
                + f"\n\n[{i + 1}/{len(snaps)}]  n/Enter next  p previous  g first  G last  q quit"
            )
            sys.stdout.flush()
            key = sys.stdin.read(1)
            if key in ("q", "\x1b", ""):
                break
            if key in ("n", "\n", " ", "j"):
                i = min(len(snaps) - 1, i + 1)
            elif key in ("p", "b", "k"):
                i = max(0, i - 1)
            elif key == "g":
                i = 0
            elif key == "G":
                i = len(snaps) - 1
    finally:
        termios.tcsetattr(fd, termios.TCSADRAIN, saved)
        sys.stdout.write("\n")
    return 0


def _recover(args: argparse.Namespace) -> int:
    from mission.logs.recover import recover

    src = Path(args.log)
    dst = Path(args.out) if args.out else src.with_suffix(".recovered.mcap")
    try:
        r = recover(src, dst)
    except (OSError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    span = (
        f"{(r.last_ns - r.first_ns) / 1e9:.1f} s" if r.first_ns is not None and r.last_ns is not None else "no messages"
    )
    state = f"cut at: {r.stop_reason}" if r.stop_reason else "the input was complete"
    print(
        f"wrote {dst}: {r.messages} messages on {r.channels} channels ({span}), {r.attachments} attachments, "
        f"{r.metadata} metadata records; {state}"
    )
    return 0
