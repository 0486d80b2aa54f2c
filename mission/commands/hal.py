"""``maris hal check CONFIG``: connect to every device of a HAL config and report.

Prints one table: a row per device role (state and why), sub-rows per part
(each CANopen drive; the vehicle's autopilot link, DVL, AHRS; ...) with their
diagnostics, then notes (e.g. optional objects an EDS lacks). Every device is
listed, also after one failed. ``--json`` prints the same as JSON. Exit status:
0 when every device is usable, 1 when any failed, is missing or faulted, 2 when
the config itself is invalid. ``--reset-faults`` resets drive faults first (the
documented preflight reset, see docs/faults.md) and says what each fault was.
The arm's joints are checked against the model (``--model URDF``, default the
shipped one). Imports stay inside the functions so ``maris --help`` stays fast.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from mission.commands._common import paint, print_json

# Imports inside the functions below are deliberate: shell completion (argcomplete) builds
# the parser on every Tab, so a command loads its heavy modules only when it runs.

#: Diagnostics keys shown in the table with a shorter name.
SHORT = {"heartbeat_age_s": "hb_age_s", "host_heartbeat_watch_s": "host_hb_watch_s", "statusword": "sw"}
#: Part keys the table shows in its own columns.
COLUMNS = ("name", "state", "detail")


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("hal", help="hardware abstraction layer tools (check devices)")
    sub = p.add_subparsers(dest="hal_command", metavar="HAL_COMMAND")
    chk = sub.add_parser("check", help="connect to every configured device and print its state")
    chk.add_argument("config", help="HAL config YAML (e.g. hal/configs/sim.yaml)")
    chk.add_argument(
        "--wait",
        type=float,
        default=6.0,
        help="seconds to let devices come up before judging (default 6; ends as soon as all are usable and none is still starting, e.g. the stereo detector before its first pair)",
    )
    chk.add_argument("--json", action="store_true", help="print the report as JSON")
    chk.add_argument(
        "--reset-faults", action="store_true", help="reset drive faults (left disabled) and report what they were"
    )
    chk.add_argument(
        "--model", metavar="URDF", help="check the arm's joints against this URDF (default: the shipped model)"
    )
    chk.set_defaults(func=run_check)
    p.set_defaults(func=lambda args: (p.print_help(), 2)[1])


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.3g}"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{k}: {_fmt(x)}" for k, x in v.items()) + "}"
    if isinstance(v, list):
        return "[" + ", ".join(_fmt(x) for x in v) + "]"
    return str(v)


def diagnostics(d: dict) -> str:
    """``key=value`` pairs of everything but the table's own columns (None values left out)."""
    return "  ".join(f"{SHORT.get(k, k)}={_fmt(v)}" for k, v in d.items() if k not in COLUMNS and v is not None)


#: Colours of the states (on a terminal; ``maris --color``).
STATE_STYLE = {"ok": "green", "degraded": "yellow", "fault": "bold red", "missing": "bold red", "failed": "bold red"}


def format_table(report: Any) -> str:
    """The report as a text table (see the module docstring)."""

    names = [f"{r.role} ({r.driver})" for r in report.rows]
    names += ["  " + str(part.get("name", "?")) for r in report.rows for part in r.parts]
    w = max([len("DEVICE"), *map(len, names)])
    pad = " " * w
    lines = [f"HAL config {report.config}: {len(report.rows)} device(s)", f"{'DEVICE':<{w}} {'STATE':<9} DETAIL"]
    for r in report.rows:
        state = paint(f"{r.state.upper():<9}", STATE_STYLE.get(r.state, "bold"))
        lines.append(f"{r.role + ' (' + r.driver + ')':<{w}} {state} {r.detail}".rstrip())
        extra = diagnostics(r.info)
        if extra:
            lines.append(f"{pad} {'':<9} {extra}")
        for part in r.parts:
            name = "  " + str(part.get("name", "?"))
            text = "  ".join(x for x in (str(part.get("detail") or ""), diagnostics(part)) if x)
            lines.append(f"{name:<{w}} {str(part.get('state', '?')):<9} {text}".rstrip())
        for note in r.notes:
            lines.append(f"{pad} note: {note}")
        for reset in r.reset:
            lines.append(f"{pad} fault reset: {reset}")
        for what in r.unheard:
            lines.append(f"{pad} not heard since the start: {what}")
    bad = [r.role for r in report.rows if not r.ok]
    lines.append("all devices healthy" if not bad else f"NOT healthy: {', '.join(bad)}")
    names = [w.split(" ", 1)[0] for r in report.rows for w in r.unheard]
    if names:
        lines.append(
            f"`maris run` refuses to start without {', '.join(names)} unless told: --allow-missing {','.join(names)}"
        )
    return "\n".join(lines)


def run_check(args: argparse.Namespace) -> int:
    from hal.check import check_hal
    from hal.config import load_hal_config
    from maris_common.yamlsrc import ConfigError

    try:
        config = load_hal_config(args.config)
    except ConfigError as exc:
        print(f"invalid HAL config:\n{exc}", file=sys.stderr)
        return 2
    if config.uses_simulator:
        import sim_backend  # noqa: F401 - registers the simulator with hal.backends; heavy, so only when a role needs it
    try:
        from kcl.model import UvmsModel

        model_joints = list(UvmsModel.load(args.model).joint_names)
    except ConfigError as exc:
        print(f"invalid model:\n{exc}", file=sys.stderr)
        return 2
    report = check_hal(config, wait=args.wait, reset_faults=args.reset_faults, model_joints=model_joints)

    try:
        if args.json:
            print_json(report.to_dict())
        else:
            print(format_table(report), flush=True)
    except BrokenPipeError:
        pass
    return 0 if report.ok else 1
