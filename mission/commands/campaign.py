"""``maris campaign``: Monte Carlo runs of one mission on a simulator scenario.

Writes ``OUT/campaign.csv`` (one row per run), ``OUT/campaign.png`` (success
rate with its Wilson 95 % interval, outcome shares), ``OUT/summary.txt`` (the
table printed at the end) and, with ``--logs``, one MCAP log per run in
``OUT/logs/``. The same ``--seed`` gives the same table and CSV, whatever
``--workers`` or the cluster does.

``maris campaign --paper`` is a different mode: it runs the MARIS three-
configuration experiment from fixed seeds and regenerates ``docs/results.md``
(see :mod:`mission.campaign.paper`).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from mission.commands._common import print_json, resolve_mission

# Imports inside the functions below are deliberate: shell completion (argcomplete) builds
# the parser on every Tab, so a command loads its heavy modules only when it runs.

#: default wall-clock limit of one campaign run, s: far above a normal run
#: (seconds), low enough that a hung run does not hold a worker for the night
DEFAULT_RUN_TIMEOUT_S = 600.0


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "campaign",
        help="Monte Carlo campaign: N randomized simulator runs, success rate with 95 %% CI",
        description="Run a mission N times on a simulator scenario with randomized pipe pose, start pose, "
        "noise and turbidity (deterministic from --seed), in parallel, and report the success "
        "rate with a Wilson 95 % confidence interval and the failure causes (table, CSV, PNG). "
        "With --paper: reproduce the MARIS field result and regenerate docs/results.md.",
    )
    p.add_argument("mission", nargs="?", help="mission file (.yaml); not used with --paper")
    p.add_argument("--scenario", help="simulator scenario name (e.g. pool_clear) or path")
    p.add_argument("--runs", type=int, help="number of runs (default 20; --paper: 50 per configuration)")
    p.add_argument("--seed", type=int, default=0, help="campaign seed; run i's seed is derived from it (default 0)")
    p.add_argument("--workers", type=int, default=None, help="local worker processes (default: CPU count)")
    p.add_argument(
        "--address",
        help="Dask scheduler address (tcp://host:8786): run on that cluster instead "
        "(workers: `dask worker ADDRESS --nthreads 1`)",
    )
    p.add_argument(
        "--run-timeout",
        type=float,
        default=DEFAULT_RUN_TIMEOUT_S,
        metavar="SECONDS",
        help="wall-clock limit of one run; a run past it is recorded as an error "
        f"(default {DEFAULT_RUN_TIMEOUT_S:g}; 0 = no limit)",
    )
    p.add_argument(
        "--set",
        dest="settings",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="scenario override (dotted key, YAML value) or controller option "
        "(controller.compensation=false, controller.filter_cutoff_rad_s=.inf); repeatable",
    )
    p.add_argument(
        "--out", help="output directory (default campaign-<mission>-<scenario>-seed<K>; --paper: docs/results.md)"
    )
    p.add_argument("--logs", action="store_true", help="keep each run's MCAP log in OUT/logs/")
    p.add_argument("--quiet", action="store_true", help="no progress output")
    p.add_argument(
        "--render-only",
        action="store_true",
        help="with --paper: re-render docs/results.md from the records of the last regeneration "
        "(docs/results/records.json), without running anything",
    )
    p.add_argument(
        "--json", action="store_true", help="print the summary as one JSON document on stdout (implies --quiet)"
    )
    p.add_argument(
        "--paper",
        action="store_true",
        help="run the MARIS experiment (four configurations, like the field campaigns) from fixed seeds "
        "and write docs/results.md",
    )
    p.set_defaults(func=_main)


def _err(msg: str) -> int:
    print(f"error: {msg}", file=sys.stderr)
    return 2


def _main(args: argparse.Namespace) -> int:
    from maris_common.yamlsrc import ConfigError
    from mission.campaign.cluster import ClusterError

    if args.workers is not None and args.workers < 1:
        return _err("--workers must be >= 1")
    if args.runs is not None and args.runs < 1:
        return _err("--runs must be >= 1")
    if args.seed < 0:
        return _err("--seed must be >= 0")
    if not args.run_timeout >= 0:
        return _err("--run-timeout must be >= 0 seconds (0 = no limit)")
    try:
        if args.paper:
            return _paper(args)
        return _campaign(args)
    except ConfigError as exc:
        print(f"error: invalid input:\n{exc}", file=sys.stderr)
        return 2
    except ClusterError as exc:
        return _err(str(exc))


def _campaign(args: argparse.Namespace) -> int:
    from mission.campaign.executor import default_workers, execute
    from mission.campaign.overrides import collect_settings
    from mission.campaign.plan import plan_campaign
    from mission.campaign.progress import Progress
    from mission.campaign.report import format_table, plot_summaries, write_csv
    from mission.campaign.single import check_inputs
    from mission.campaign.stats import summarize

    if not args.mission:
        return _err("a mission file is required (or use --paper)")

    args.mission = resolve_mission(args.mission)
    args.quiet = args.quiet or args.json
    if not args.scenario:
        return _err("--scenario is required (e.g. --scenario pool_clear)")
    settings, issues = collect_settings(args.settings)
    check_inputs(args.mission, args.scenario, settings, issues)
    runs = args.runs or 20
    out = Path(args.out or f"campaign-{Path(args.mission).stem}-{Path(args.scenario).stem}-seed{args.seed}")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        return _err(f"cannot create the output directory {out}: {exc.strerror or exc}")
    mission, scenario, log_dir = args.mission, args.scenario, (out / "logs") if args.logs else None
    if args.address:  # workers have their own working directory: give them absolute paths
        mission = str(Path(mission).resolve())
        scenario = str(Path(scenario).resolve()) if Path(scenario).is_file() else scenario
        log_dir = log_dir.resolve() if log_dir is not None else None
    plan = plan_campaign(
        mission,
        scenario,
        runs,
        args.seed,
        overrides=settings.scenario,
        controller=settings.controller,
        log_dir=log_dir,
        timeout_s=args.run_timeout or None,
    )
    where = f"cluster {args.address}" if args.address else f"{args.workers or default_workers()} local workers"
    if not args.quiet:
        print(f"campaign: {runs} runs of {args.mission} on {args.scenario}, seed {args.seed}, {where}", file=sys.stderr)
    progress = None if args.quiet else Progress(runs)
    records = execute(plan, workers=args.workers, address=args.address, on_record=progress)
    title = f"campaign: {args.mission} on {args.scenario}, {runs} runs, seed {args.seed}" + (
        f", set {' '.join(args.settings)}" if args.settings else ""
    )
    criterion = "grasp" if mission_grasps(args.mission) else "mission"
    table = format_table(records, title, criterion)
    (out / "summary.txt").write_text(table + "\n")
    write_csv(records, out / "campaign.csv")
    plot_summaries(
        [(Path(args.scenario).stem, summarize(records))], out / "campaign.png", title=title, criterion=criterion
    )
    if args.json:
        from mission.campaign.stats import summarize_attempts

        s = summarize(records)
        a = summarize_attempts(records)
        print_json(
            {
                "mission": args.mission,
                "scenario": args.scenario,
                "runs": runs,
                "seed": args.seed,
                "criterion": criterion,
                "successes": s.successes,
                "rate": s.rate,
                "ci95": list(s.ci95),
                "counts": s.counts,
                "out": str(out),
                "attempts": {
                    "attempts": a.attempts,
                    "successes": a.successes,
                    "rate": a.rate,
                    "ci95": list(a.ci95),
                    "counts": a.counts,
                },
                "records": [
                    {k: v for k, v in r.to_dict().items() if k not in ("traceback", "wall_s")} for r in records
                ],
            }
        )
        return 0
    print(table)
    print(
        f"wrote {out / 'campaign.csv'}, {out / 'campaign.png'}, {out / 'summary.txt'}"
        + (f", logs in {out / 'logs'}" if args.logs else "")
    )
    return 0


def _paper(args: argparse.Namespace) -> int:
    from mission.campaign.paper_run import regenerate

    if args.mission or args.scenario or args.settings:
        return _err("--paper uses the reference mission and the pool scenarios; drop MISSION/--scenario/--set")
    if args.render_only:
        from mission.campaign.paper_run import rerender

        try:
            rerender(out=args.out or "docs/results.md")
        except FileNotFoundError as exc:
            return _err(f"no records to re-render ({exc.filename}): run `maris campaign --paper` first")
        return 0
    regenerate(
        out=args.out or "docs/results.md",
        runs=args.runs or 50,
        seed=args.seed,
        workers=args.workers,
        address=args.address,
        quiet=args.quiet,
    )
    return 0


def mission_grasps(path: str) -> bool:
    """Whether the mission's main tree tries a grasp (a ``grasp`` action or a
    gripper ``close``): its success is then judged by the object held, else
    by the mission's own outcome."""
    from mission.loader import load_mission

    mission = load_mission(path)
    todo, seen = [mission.tree], set()
    while todo:
        node = todo.pop()
        for n in node.walk():
            if (n.kind == "action" and n.params.get("run") == "grasp") or (
                n.kind == "gripper" and n.params.get("command") == "close"
            ):
                return True
            use = n.use if n.kind == "subtree" else ""
            if use in mission.subtrees and use not in seen:
                seen.add(use)
                todo.append(mission.subtrees[use])
    return False
