"""``maris calibrate LOG.mcap... [--base SCENARIO] [--out FILE]``: fit simulator parameters to logs.

Reads one or more run logs (field or simulator), fits what they determine
(vehicle velocity response per DOF, DVL rate/noise/losses, gyro noise,
detection probability and visibility; see :mod:`mission.calibration.calibrate`)
and writes a scenario file that extends ``--base`` with the fitted values and
their uncertainty. Exit 0 on success; 1 with a clear message for unreadable
logs or logs without the needed topics.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

# Imports inside the functions below are deliberate: shell completion (argcomplete) builds
# the parser on every Tab, so a command loads its heavy modules only when it runs.


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "calibrate",
        help="fit the simulator's vehicle and sensor parameters to run logs, write a scenario",
        description="Fit what run logs determine - the vehicle's velocity response (commanded vs DVL / gyro), "
        "DVL rate, noise and lost pings, gyro noise, detection probability and visibility - and write a "
        "scenario file extending --base with the fitted values and their one-sigma uncertainty.",
    )
    p.add_argument("logs", nargs="+", metavar="LOG.mcap", help="run logs (maris sim / maris run --log)")
    p.add_argument("--base", default="pool_clear", help="scenario the result extends (default pool_clear)")
    p.add_argument("--turbidity", default="clear", help="water of the logs, for the vision fits (default clear)")
    p.add_argument("--out", default="calibrated.yaml", help="scenario file to write (default calibrated.yaml)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from maris_common.yamlsrc import ConfigError
    from mission.calibration.calibrate import calibrate
    from mission.calibration.logdata import read_logs
    from mission.calibration.output import scenario_text, summary_table
    from mission.logs.reader import LogError
    from sim_backend import load_scenario
    from sim_backend.schema import TURBIDITY_LEVELS

    missing = [p for p in args.logs if not Path(p).is_file()]
    if missing:
        print(f"maris calibrate: no such file: {', '.join(missing)}", file=sys.stderr)
        return 1
    if args.turbidity not in TURBIDITY_LEVELS:
        print(f"maris calibrate: --turbidity must be one of {', '.join(TURBIDITY_LEVELS)}", file=sys.stderr)
        return 1
    try:
        load_scenario(args.base)
        data = read_logs(args.logs)
    except ConfigError as exc:
        print(exc, file=sys.stderr)
        return 1
    except LogError as exc:
        print(f"maris calibrate: {exc}", file=sys.stderr)
        return 1
    if data.t_cmd.size == 0 or data.t_nav.size == 0:
        print(
            "maris calibrate: the logs have no /vehicle/command or /vehicle/navigation messages to fit", file=sys.stderr
        )
        return 1
    cal = calibrate(data, base=args.base, turbidity=args.turbidity)
    text = scenario_text(cal)
    out = Path(args.out)
    out.write_text(text)
    try:
        load_scenario(out)
    except ConfigError as exc:  # a fit outside the schema's bounds: say which, keep the file to inspect
        print(f"maris calibrate: the written scenario does not validate:\n{exc}", file=sys.stderr)
        return 1
    print(summary_table(cal))
    print(f"wrote {out} (extends {args.base}; use it with --scenario {out})")
    return 0
