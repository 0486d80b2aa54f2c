"""``maris run MISSION --hal CONFIG``: the mission on real devices, in real time,
with the same supervisor, safety monitors, operator keys and logs as ``maris sim``."""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING

from mission.commands._common import mission_argument
from mission.commands._runner import add_run_options, bad_filter_cutoff, execute
from mission.runtime.options import RunOptions, RunTarget

if TYPE_CHECKING:
    from hal.config import HalConfig

# Imports inside the functions below are deliberate: shell completion (argcomplete) builds
# the parser on every Tab, so a command loads its heavy modules only when it runs.


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "run",
        help="run a mission on real devices (HAL config)",
        description="Run a mission on the devices of a HAL config, in real time. "
        "Keys (on a terminal): p pause, r resume, space toggle, a/q abort. Ctrl-C or SIGTERM "
        "aborts cleanly (abort path, log closed); a second one safe-stops at once.",
    )
    mission_argument(p)
    p.add_argument(
        "--hal", required=True, metavar="CONFIG", help="HAL config YAML (e.g. hal/configs/bluerov2_canopen_arm.yaml)"
    )
    p.add_argument(
        "--reset-faults",
        action="store_true",
        help="reset drive faults at preflight (each logged with its EMCY code and error register) "
        "instead of refusing to start; see docs/faults.md",
    )
    p.add_argument(
        "--allow-missing",
        action="append",
        default=[],
        metavar="NAME",
        help="start even if this device is not heard at preflight (a vehicle sensor: dvl, ahrs, ping, or "
        "the detector or wrench_sensor); repeat or separate with commas; logged. Without it a configured "
        "device that is not heard refuses the start (docs/faults.md)",
    )
    rt = p.add_argument_group("real-time process settings (Linux; docs/performance.md)")
    rt.add_argument(
        "--rt-priority",
        type=int,
        default=None,
        metavar="N",
        help="run every thread of the run under SCHED_FIFO priority N (1-99): other work on the "
        "computer (a campaign, a compiler) cannot delay the loop; needs root or CAP_SYS_NICE",
    )
    rt.add_argument(
        "--nice",
        type=int,
        default=None,
        metavar="N",
        help="niceness -20..19 of the run's threads (negative needs privileges; no effect with --rt-priority)",
    )
    rt.add_argument(
        "--rt-affinity",
        default=None,
        metavar="CPUS",
        help="CPUs the run may use, e.g. 1 or 0,1 or 0-1 (keep other work off them with its own affinity)",
    )
    rt.add_argument(
        "--lock-memory",
        action="store_true",
        help="lock the run's memory in RAM (mlockall): no page of its code or data is paged out and "
        "faulted back in during a step; needs root, CAP_IPC_LOCK or a high memlock limit",
    )
    rt.add_argument(
        "--gil-interval",
        type=float,
        default=None,
        metavar="MS",
        help="Python's thread switch interval in ms (default 5): the longest the loop waits for the "
        "interpreter while a driver thread runs; e.g. 0.5",
    )
    rt.add_argument(
        "--no-health-prefetch",
        action="store_true",
        help="poll the devices' health on the loop thread at the tree step, as before (default: the "
        "drivers compute it between the steps, for the step that reads it; docs/performance.md)",
    )
    add_run_options(p)
    p.set_defaults(func=run_field)


def apply_process_options(args: argparse.Namespace) -> bool:
    """Apply ``--rt-priority``, ``--nice``, ``--rt-affinity``, ``--gil-interval``, ``--lock-memory`` to this process (before the
    drivers start their threads, which inherit them); sets ``args.process_applied``.
    False (after printing why) when a setting is invalid or not permitted."""
    from mission.runtime.rtprocess import ProcessSettingError, ProcessSettings, apply_process_settings, parse_cpus

    try:
        cpus = parse_cpus(args.rt_affinity) if args.rt_affinity is not None else None
        gil = None if args.gil_interval is None else args.gil_interval / 1e3
        settings = ProcessSettings(
            rt_priority=args.rt_priority,
            nice=args.nice,
            cpus=cpus,
            gil_interval_s=gil,
            lock_memory=getattr(args, "lock_memory", False),
        )
        args.process_applied = None if settings.empty else apply_process_settings(settings)
    except (ValueError, ProcessSettingError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return False
    return True


def allowed_missing(values: list[str], config: HalConfig) -> tuple[str, ...] | None:
    """The names of ``--allow-missing`` (repeated, comma-separated), each a device or vehicle
    sensor the config names; None (after printing why) when one is not."""
    from hal.check import config_entries, may_be_missing

    known = [n for n in config_entries(config) if may_be_missing(n)]
    names = tuple(dict.fromkeys(n.strip() for v in values for n in v.split(",") if n.strip()))
    unknown = [n for n in names if n not in known]
    if unknown:
        print(
            f"error: --allow-missing {', '.join(unknown)}: not a device of {config.path} a run can start "
            f"without (those are: {', '.join(known) or 'none'}; the vehicle, arm and gripper are needed)",
            file=sys.stderr,
        )
        return None
    return names


def run_field(args: argparse.Namespace) -> int:
    from maris_common.yamlsrc import ConfigError

    if bad_filter_cutoff(args) or not apply_process_options(args):
        return 2
    try:
        from hal.config import load_hal_config
        from hal.factory import build_backend

        config = load_hal_config(args.hal)
        args.allow_missing = allowed_missing(args.allow_missing, config)
        if args.allow_missing is None:
            return 2
        if config.uses_simulator:
            import sim_backend  # noqa: F401 - registers the simulator with hal.backends; heavy, so only when a role needs it

        backend = build_backend(config, realtime=True)
        if args.no_health_prefetch:
            for b in (backend, getattr(backend, "real", None)):  # a mixed backend's real part too
                if b is not None and hasattr(b, "health_prefetch"):
                    b.health_prefetch = False
    except ConfigError as exc:
        print(f"error: invalid HAL config:\n{exc}", file=sys.stderr)
        return 2
    except (OSError, RuntimeError, ValueError) as exc:
        print(f"error: cannot set up the devices of {args.hal}: {exc}", file=sys.stderr)
        return 2
    try:
        return execute(
            args,
            RunTarget(args.mission, backend=backend, hal_config=config, hal_config_path=args.hal),
            RunOptions(compensation=not args.no_compensation, filter_cutoff=args.filter_cutoff),
        )
    finally:
        # the run closes the backend; this also covers errors before the run starts
        # (bad mission, log path, live port), so no CAN bus or link stays open
        backend.close()
