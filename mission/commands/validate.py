"""``maris validate MISSION... [--hal CONFIG]``: check mission files before they run.

Exit 0 and a one-line summary per mission when all are valid; exit 1 and every
problem (``file:line:column: field: message``) otherwise. Never a traceback
for bad input: problems in the HAL config file are reported the same way.
"""

from __future__ import annotations

import argparse
import sys


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "validate",
        help="check a mission file (all errors at once, with file:line:column)",
        description="Load a mission YAML file and run every static check: keys, types, ranges, "
        "references (actions, subtrees, blackboard keys, devices with --hal) and the safety lint.",
    )
    p.add_argument("mission", nargs="+", help="mission YAML file(s)")
    p.add_argument("--hal", metavar="CONFIG", help="HAL config YAML: also check that the devices the mission needs exist")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from maris_common.yamlsrc import ConfigError

    from mission.loader import load_mission

    status = 0
    for path in args.mission:
        try:
            mission = load_mission(path, hal_config=args.hal)
        except ConfigError as exc:
            n = len(exc.issues)
            for issue in exc.issues:
                print(issue, file=sys.stderr)
            print(f"{path}: {n} problem{'s' if n != 1 else ''} found", file=sys.stderr)
            status = 1
            continue
        nodes = sum(1 for _ in mission.tree.walk())
        hal = f", devices checked against {args.hal}" if args.hal else ""
        print(f"{path}: mission `{mission.name}` is valid ({nodes} nodes in the main tree, "
              f"{len(mission.subtrees)} subtree{'s' if len(mission.subtrees) != 1 else ''}, abort path present{hal})")
    return status
