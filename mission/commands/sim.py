"""``maris sim MISSION``: dry-run a mission on the simulator, with a live
progress line, operator keys (on a TTY) and a final summary. Exit code 0 only
when the mission succeeded."""

from __future__ import annotations

import argparse
import sys

from mission.commands._runner import add_run_options, bad_filter_cutoff


def register(subparsers: argparse._SubParsersAction) -> None:
    from mission.commands._common import mission_argument, scenario_completer

    p = subparsers.add_parser(
        "sim",
        help="run a mission on the simulator (dry run)",
        description="Run a mission on the kinematic simulator and write an MCAP log. "
        "Keys while running (on a terminal): p pause, r resume, space toggle, a/q abort. "
        "Ctrl-C aborts cleanly (runs the abort path); a second Ctrl-C stops at once.",
    )
    mission_argument(p)
    p.add_argument(
        "--scenario",
        default=None,
        help="scenario name (maris scenarios list) or YAML path (default: pool_fixed, the repeatable dry-run setting)",
    ).completer = scenario_completer
    p.add_argument(
        "--hal",
        default=None,
        metavar="CONFIG",
        help="a simulator HAL config (every role `driver: sim`, e.g. hal/configs/bluerov2_sim.yaml): the mission is "
        "checked against its devices, its `model`/`actions` name the rig and its `sim.scenario` is the default scenario",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the run (default 0)")
    p.add_argument("--realtime", action="store_true", help="pace the simulation to the wall clock")
    p.add_argument("--no-log", action="store_true", help="do not write a log")
    p.add_argument(
        "--no-input-record",
        action="store_true",
        help="log without the input record that `maris log replay` needs: the log shows and plots "
        "everything as usual, it is under half the size and the dry run about 1.2x faster (docs/performance.md), "
        "but it cannot be replayed",
    )
    p.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a scenario parameter, e.g. --set dvl.dropouts='[[20, 30]]' (repeatable)",
    )
    p.add_argument(
        "--inject",
        action="append",
        default=[],
        metavar="FAULT[:JOINT]@T[+DUR]",
        help="inject a simulator fault at T s for DUR s (default: for ever), e.g. dvl_dropout@30+10, "
        "joint_fault:1@20, ahrs_nan@15; faults: dvl_dropout, vision_lost, joint_fault, gripper_fault, ahrs_nan "
        "(repeatable)",
    )
    add_run_options(p)
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


def parse_inject(item: str) -> dict:
    """``"joint_fault:1@20+5"`` -> ``{"fault": "joint_fault", "joint": 1, "start": 20.0, "duration": 5.0}``."""
    head, sep, when = item.partition("@")
    if not sep:
        raise ValueError(f"--inject expects FAULT[:JOINT]@T[+DUR], got {item!r}")
    fault, _, joint = head.partition(":")
    start, _, duration = when.partition("+")
    try:
        spec = {"fault": fault.strip(), "start": float(start), "duration": float(duration) if duration else None}
    except ValueError:
        raise ValueError(f"--inject {item!r}: T and DUR must be numbers of seconds") from None
    if spec["start"] < 0 or (spec["duration"] is not None and spec["duration"] <= 0):
        raise ValueError(f"--inject {item!r}: T must be >= 0 and DUR > 0")
    if joint:
        spec["joint"] = int(joint) if joint.strip().isdigit() else joint.strip()
    return spec


def run_sim(args: argparse.Namespace) -> int:
    if bad_filter_cutoff(args):
        return 2
    try:
        overrides = parse_sets(args.set)
        injections = [parse_inject(item) for item in args.inject]
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    from sim_backend.backend import FAULTS

    for spec in injections:
        if spec["fault"] not in FAULTS:
            print(f"error: --inject: unknown fault `{spec['fault']}`; known: {', '.join(FAULTS)}", file=sys.stderr)
            return 2
        if spec["fault"] == "joint_fault" and "joint" not in spec:
            print("error: --inject joint_fault needs a joint, e.g. joint_fault:1@20", file=sys.stderr)
            return 2

    class InjectError(Exception):
        pass

    def inject_all(supervisor) -> None:
        for spec in injections:
            try:
                supervisor.backend.inject(**spec)
            except ValueError as exc:  # e.g. a joint name the arm does not have
                raise InjectError(str(exc)) from None

    hal: dict = {}
    scenario = args.scenario
    if args.hal is not None:
        from hal.config import load_hal_config
        from maris_common.yamlsrc import ConfigError

        try:
            config = load_hal_config(args.hal)
        except ConfigError as exc:
            print(f"error: invalid HAL config:\n{exc}", file=sys.stderr)
            return 2
        if not config.is_sim:
            print(
                f"error: --hal {args.hal}: not every role is `driver: sim`; run real devices with `maris run --hal`",
                file=sys.stderr,
            )
            return 2
        hal = {"hal_config": config, "hal_config_path": args.hal}
        scenario = scenario or config.scenario
    from mission.commands._runner import execute

    try:
        return execute(
            args,
            **hal,
            scenario=scenario,
            seed=args.seed,
            overrides=overrides,
            realtime=args.realtime,
            compensation=not args.no_compensation,
            filter_cutoff=args.filter_cutoff,
            record_inputs=not args.no_input_record,
            on_supervisor=inject_all if injections else None,
        )
    except InjectError as exc:
        print(f"error: --inject: {exc}", file=sys.stderr)
        return 2
