"""``maris run MISSION --hal CONFIG``: the mission on real devices, in real time,
with the same supervisor, safety monitors, operator keys and logs as ``maris sim``."""

from __future__ import annotations

import argparse
import sys

from mission.commands._runner import add_run_options, bad_filter_cutoff


def register(subparsers: argparse._SubParsersAction) -> None:
    from mission.commands._common import mission_argument

    p = subparsers.add_parser(
        "run", help="run a mission on real devices (HAL config)",
        description="Run a mission on the devices of a HAL config, in real time. "
        "Keys (on a terminal): p pause, r resume, space toggle, a/q abort. Ctrl-C or SIGTERM "
        "aborts cleanly (abort path, log closed); a second one safe-stops at once.",
    )
    mission_argument(p)
    p.add_argument("--hal", required=True, metavar="CONFIG", help="HAL config YAML (e.g. hal/configs/bluerov2_canopen_arm.yaml)")
    p.add_argument("--reset-faults", action="store_true",
                   help="reset drive faults at preflight (each logged with its EMCY code and error register) "
                        "instead of refusing to start; see docs/faults.md")
    add_run_options(p)
    p.set_defaults(func=run_field)


def run_field(args: argparse.Namespace) -> int:
    from maris_common.yamlsrc import ConfigError

    if bad_filter_cutoff(args):
        return 2
    try:
        from hal.config import load_hal_config
        from hal.factory import build_backend

        config = load_hal_config(args.hal)
        backend = build_backend(config, realtime=True)
    except ConfigError as exc:
        print(f"error: invalid HAL config:\n{exc}", file=sys.stderr)
        return 2
    except (OSError, RuntimeError, ValueError) as exc:
        print(f"error: cannot set up the devices of {args.hal}: {exc}", file=sys.stderr)
        return 2
    from mission.commands._runner import execute

    try:
        return execute(args, backend=backend, hal_config=config, hal_config_path=args.hal,
                       compensation=not args.no_compensation, filter_cutoff=args.filter_cutoff)
    finally:
        # the run closes the backend; this also covers errors before the run starts
        # (bad mission, log path, live port), so no CAN bus or link stays open
        backend.close()
