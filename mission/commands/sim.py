"""``maris sim MISSION``: dry-run a mission on the simulator, with a live
progress line, operator keys (on a TTY) and a final summary. Exit code 0 only
when the mission succeeded."""

from __future__ import annotations

import argparse
import sys


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "sim", help="run a mission on the simulator (dry run)",
        description="Run a mission on the kinematic simulator and write an MCAP log. "
        "Keys while running (on a terminal): p pause, r resume, space toggle, a/q abort. "
        "Ctrl-C aborts cleanly (runs the abort path); a second Ctrl-C stops at once.",
    )
    p.add_argument("mission", help="mission YAML file")
    p.add_argument("--scenario", default=None, help="scenario name (sim_backend/scenarios) or YAML path (default: pool_fixed, the repeatable dry-run setting)")
    p.add_argument("--seed", type=int, default=0, help="seed of the run (default 0)")
    p.add_argument("--realtime", action="store_true", help="pace the simulation to the wall clock")
    p.add_argument("--log", default=None, metavar="PATH", help="log file (default runs/<mission>-<timestamp>.mcap)")
    p.add_argument("--no-log", action="store_true", help="do not write a log")
    p.add_argument("--no-compensation", action="store_true", help="arm does not compensate measured vehicle velocity")
    p.add_argument("--filter-cutoff", type=float, default=50.0, metavar="W",
                   help="cut-off of the angular-rate filter, rad/s (default 50)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scenario parameter, e.g. --set dvl.dropouts='[[20, 30]]' (repeatable)")
    p.add_argument("--quiet", action="store_true", help="no progress line, only the final summary")
    p.add_argument("--live", nargs="?", type=int, const=8765, default=None, metavar="PORT",
                   help="serve the log channels to Foxglove at ws://127.0.0.1:PORT while running (default port 8765)")
    p.set_defaults(func=run_sim)


def parse_sets(items: list[str]) -> dict[str, str]:
    """``["a.b=1", ...]`` -> ``{"a.b": "1"}`` (values parsed as YAML by the scenario loader)."""
    out = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise ValueError(f"--set expects KEY=VALUE, got {item!r}")
        out[key.strip()] = value.strip()
    return out


def run_sim(args: argparse.Namespace) -> int:
    if not (args.filter_cutoff > 0):
        print(f"error: --filter-cutoff must be positive, got {args.filter_cutoff}", file=sys.stderr)
        return 2
    try:
        overrides = parse_sets(args.set)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    from mission.commands._runner import execute

    return execute(args, scenario=args.scenario, seed=args.seed, overrides=overrides, realtime=args.realtime,
                   compensation=not args.no_compensation, filter_cutoff=args.filter_cutoff)
