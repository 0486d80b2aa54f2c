"""Instruction counts of the dry run and of a campaign run (valgrind's callgrind):
the figure to decide code changes on when wall time is noisy (a shared machine).

Runs a mission (``missions/maris_pipe_recovery.yaml`` unless ``--mission``) on the simulator once to warm up
(imports, model, compiled kernels: not counted), then once more with callgrind
counting only the part asked for, and prints instructions per base step
(10 ms of mission) of that part. Callgrind counts the instructions the CPU
executes (all of this process's threads), whatever else loads the machine, so
two counts of the same code agree to ~0.1 %; a run under callgrind takes
~50x its normal time (about 2-4 minutes here).

    .venv/bin/python benchmarks/support/instructions.py [--what loop|run] [--log] [--no-input-record]
                                                [--mission FILE] [--scenario pool_fixed] [--seed 1] [--model full|first_order]

``--what loop`` (default): the supervisor loop only (``SupervisorLoop.run``: every
step from the preflight to the end state), ``run``: the whole ``run_mission``
call (loading the mission, models and scenario, building the trees, the loop,
closing the log) in a process that ran the mission once already, as a campaign
worker does for every run after its first. Without ``--log`` no log is written
(a campaign that keeps no per-run logs); ``--log`` writes one (the input record
included unless ``--no-input-record``), as ``maris sim`` does.

``MARIS_INSTRUCTIONS_CALLGRIND_OUT=FILE`` keeps callgrind's profile (for
``callgrind_annotate FILE``: which functions the instructions went to).

Not run by ``make bench`` (it takes minutes). Needs valgrind (``apt-get install valgrind``). Last line:
``instructions what=<loop|run> log=<0|1> record=<0|1> per_step=<n> total=<n> steps=<n>``.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
_CHILD = "MARIS_INSTRUCTIONS_CHILD"


def _control(flag: str) -> None:
    """Switch callgrind's instrumentation of this process on or off."""
    subprocess.run(["callgrind_control", "-i", flag, str(os.getpid())], check=True, capture_output=True)


def _workload(args: argparse.Namespace, out: Path) -> None:
    """Child side (under valgrind): warm up, then the counted run. Writes the step count to ``out``."""
    sys.path.insert(0, str(ROOT))
    import mission.replay.record  # noqa: F401 - registers the input record of the run's log
    from mission.runtime.api import run_mission
    from mission.runtime.loop import SupervisorLoop
    from mission.runtime.options import RunOptions, RunTarget

    overrides = {"vehicle.model": args.model} if args.model else None
    with tempfile.TemporaryDirectory() as tmp:

        def once(counted: bool) -> int:
            log = Path(tmp) / ("counted.mcap" if counted else "warm.mcap") if args.log else None
            if counted and args.what == "run":
                _control("on")
            result = run_mission(
                RunTarget(
                    Path(args.mission),
                    scenario=args.scenario,
                    seed=args.seed,
                    overrides=overrides,
                ),
                RunOptions(log_path=log, record_inputs=not args.no_input_record),
            )
            if counted and args.what == "run":
                _control("off")
            return int(result.metrics["steps"])

        once(False)
        if args.what == "loop":
            inner = SupervisorLoop.run

            def counted_loop(self: SupervisorLoop, t0: float) -> None:
                _control("on")
                try:
                    inner(self, t0)
                finally:
                    _control("off")

            SupervisorLoop.run = counted_loop  # type: ignore[method-assign]
        steps = once(True)
    out.write_text(str(steps))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--what", choices=("loop", "run"), default="loop")
    ap.add_argument("--log", action="store_true", help="write a run log (as maris sim does)")
    ap.add_argument("--no-input-record", action="store_true", help="with --log: without the input record")
    ap.add_argument(
        "--mission",
        default=str(ROOT / "missions" / "maris_pipe_recovery.yaml"),
        help="mission file (e.g. another tree's copy, to count two versions of the code on one mission)",
    )
    ap.add_argument("--scenario", default="pool_fixed")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--model", choices=("full", "first_order"), default=None)
    ap.add_argument("--steps-file", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if os.environ.get(_CHILD):
        _workload(args, Path(args.steps_file))
        return 0
    if shutil.which("valgrind") is None or shutil.which("callgrind_control") is None:
        print("valgrind (callgrind) is not installed: apt-get install valgrind", file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory() as tmp:
        steps_file = Path(tmp) / "steps"
        cg_out = Path(os.environ.get("MARIS_INSTRUCTIONS_CALLGRIND_OUT", Path(tmp) / "callgrind.out"))
        cmd = [
            "valgrind",
            "--tool=callgrind",
            "--instr-atstart=no",
            f"--callgrind-out-file={cg_out}",
            sys.executable,
            __file__,
            *sys.argv[1:],
            "--steps-file",
            str(steps_file),
        ]
        proc = subprocess.run(cmd, env={**os.environ, _CHILD: "1"}, capture_output=True, text=True)
        found = re.search(r"Collected\s*:\s*(\d+)", proc.stderr)
        if proc.returncode != 0 or not found or not steps_file.exists():
            print(proc.stdout[-2000:], proc.stderr[-4000:], sep="\n", file=sys.stderr)
            return 1
        total = int(found.group(1))
        steps = int(steps_file.read_text())
    log, record = int(args.log), int(args.log and not args.no_input_record)
    print(
        f"mission {Path(args.mission).name} scenario={args.scenario} seed={args.seed} "
        f"vehicle.model={args.model or 'scenario default'} log={'on' if log else 'off'}"
        f"{' (input record ' + ('on' if record else 'off') + ')' if log else ''}"
    )
    print(
        f"counted: {'the supervisor loop' if args.what == 'loop' else 'run_mission in a warm process'}, "
        f"{steps} base steps"
    )
    print(f"instructions: {total:,} total, {total / steps:,.0f} per step")
    print(
        f"instructions what={args.what} log={log} record={record} per_step={total / steps:.0f} total={total} steps={steps}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
