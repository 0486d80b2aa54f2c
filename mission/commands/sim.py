"""``maris sim MISSION``: dry-run a mission on the simulator, with a live
progress line, operator keys (on a TTY) and a final summary. Exit code 0 only
when the mission succeeded."""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol, runtime_checkable

from mission.commands._common import mission_argument, scenario_completer
from mission.commands._runner import add_run_options, bad_filter_cutoff, execute
from mission.runtime.options import RunOptions, RunTarget

if TYPE_CHECKING:
    from mission.runtime.supervisor import Supervisor

# Imports inside the functions below are deliberate: shell completion (argcomplete) builds
# the parser on every Tab, so a command loads its heavy modules only when it runs.


def register(subparsers: argparse._SubParsersAction) -> None:
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
        "everything as usual, it is smaller and the dry run faster (docs/performance.md), "
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


@dataclass(frozen=True)
class Injection:
    """One ``--inject``: ``fault`` from ``start`` (s) for ``duration`` (s, None: for ever) on
    ``joint`` (index or name, None: not a joint's fault)."""

    fault: str
    start: float
    duration: float | None = None
    joint: int | str | None = None


@runtime_checkable
class FaultInjection(Protocol):
    """A backend that takes injected faults (the simulator, through the input record too)."""

    def inject(
        self, fault: str, start: float | None = None, duration: float | None = None, joint: int | str | None = None
    ) -> None: ...


def parse_inject(item: str) -> Injection:
    """``"joint_fault:1@20+5"`` -> ``Injection("joint_fault", 20.0, 5.0, joint=1)``."""
    head, sep, when = item.partition("@")
    if not sep:
        raise ValueError(f"--inject expects FAULT[:JOINT]@T[+DUR], got {item!r}")
    fault, _, joint = head.partition(":")
    start, _, duration = when.partition("+")
    try:
        start_s, duration_s = float(start), float(duration) if duration else None
    except ValueError:
        raise ValueError(f"--inject {item!r}: T and DUR must be numbers of seconds") from None
    if start_s < 0 or (duration_s is not None and duration_s <= 0):
        raise ValueError(f"--inject {item!r}: T must be >= 0 and DUR > 0")
    which: int | str | None = None
    if joint:
        which = int(joint) if joint.strip().isdigit() else joint.strip()
    return Injection(fault.strip(), start_s, duration_s, which)


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
        if spec.fault not in FAULTS:
            print(f"error: --inject: unknown fault `{spec.fault}`; known: {', '.join(FAULTS)}", file=sys.stderr)
            return 2
        if spec.fault == "joint_fault" and spec.joint is None:
            print("error: --inject joint_fault needs a joint, e.g. joint_fault:1@20", file=sys.stderr)
            return 2

    class InjectError(Exception):
        pass

    def inject_all(supervisor: Supervisor) -> None:
        backend = supervisor.backend
        if not isinstance(backend, FaultInjection):
            raise InjectError("this backend takes no injected faults")
        for spec in injections:
            try:
                backend.inject(spec.fault, start=spec.start, duration=spec.duration, joint=spec.joint)
            except ValueError as exc:  # e.g. a joint name the arm does not have
                raise InjectError(str(exc)) from None

    hal_config, scenario = None, args.scenario
    if args.hal is not None:
        from hal.config import load_hal_config  # (command modules import lightly: shell completion)
        from maris_common.yamlsrc import ConfigError

        try:
            hal_config = load_hal_config(args.hal)
        except ConfigError as exc:
            print(f"error: invalid HAL config:\n{exc}", file=sys.stderr)
            return 2
        if not hal_config.is_sim:
            print(
                f"error: --hal {args.hal}: not every role is `driver: sim`; run real devices with `maris run --hal`",
                file=sys.stderr,
            )
            return 2
        scenario = scenario or hal_config.scenario
    try:
        return execute(
            args,
            RunTarget(
                args.mission,
                scenario=scenario,
                seed=args.seed,
                overrides=overrides,
                hal_config=hal_config,
                hal_config_path=args.hal if hal_config is not None else None,
            ),
            RunOptions(
                realtime=args.realtime,
                compensation=not args.no_compensation,
                filter_cutoff=args.filter_cutoff,
                record_inputs=not args.no_input_record,
            ),
            on_supervisor=inject_all if injections else None,
        )
    except InjectError as exc:
        print(f"error: --inject: {exc}", file=sys.stderr)
        return 2
