"""``maris show MISSION [--dot FILE] [--png FILE]``: display a mission's trees.

Prints the main tree and the abort tree in the terminal (py_trees' unicode
rendering); ``--dot`` writes a Graphviz file (pydot), ``--png`` renders the tree with the
graphviz ``dot`` program when it is installed, else with matplotlib
(:mod:`mission.tree_png`).
"""

from __future__ import annotations

import argparse
import shutil
import sys


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "show",
        help="print a mission's behaviour tree (or write it as .dot / .png)",
        description="Load a mission and print its behaviour tree and abort tree.",
    )
    p.add_argument("mission", help="mission YAML file")
    p.add_argument("--dot", metavar="FILE", help="also write the tree as a Graphviz .dot file")
    p.add_argument("--png", metavar="FILE", help="also render the tree to a PNG (graphviz `dot` if installed, else matplotlib)")
    p.add_argument("--ascii", action="store_true", help="plain ASCII instead of unicode symbols")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from maris_common.yamlsrc import ConfigError

    from mission.loader import load_mission

    try:
        mission = load_mission(args.mission)
    except ConfigError as exc:
        for issue in exc.issues:
            print(issue, file=sys.stderr)
        print(f"{args.mission}: not shown, fix the problems above (maris validate)", file=sys.stderr)
        return 1

    import py_trees

    from mission.compiler import compile_abort, compile_mission

    render = py_trees.display.ascii_tree if args.ascii else py_trees.display.unicode_tree
    root = compile_mission(mission, None)
    abort = compile_abort(mission, None)
    print(f"mission: {mission.name}" + (f" - {mission.description}" if mission.description else ""))
    for line in _summary(mission):
        print(f"  {line}")
    print(render(root))
    print("abort path:")
    print(render(abort))
    if not (args.dot or args.png):
        return 0
    combined = py_trees.composites.Parallel(
        f"{mission.name} (main | abort)", policy=py_trees.common.ParallelPolicy.SuccessOnAll(), children=[root, abort]
    )
    graph = py_trees.display.dot_tree(combined)
    status = 0
    if args.dot:
        try:
            with open(args.dot, "w", encoding="utf-8") as fh:
                fh.write(graph.to_string())
            print(f"wrote {args.dot}")
        except OSError as exc:
            print(f"cannot write {args.dot}: {exc}", file=sys.stderr)
            status = 1
    if args.png:
        try:
            if shutil.which("dot") is not None:
                graph.write_png(args.png)
            else:  # no Graphviz: draw it with matplotlib instead
                from mission.tree_png import write_tree_png

                write_tree_png(combined, args.png, title=f"{mission.name}: main tree | abort path")
            print(f"wrote {args.png}")
        except Exception as exc:  # noqa: BLE001 - report rendering failures, no traceback
            print(f"cannot write {args.png}: {exc}", file=sys.stderr)
            status = 1
    return status


def _summary(mission) -> list[str]:
    """Rates, safety envelope and blackboard, one line each."""
    r, sf = mission.rates, mission.safety
    g = sf.geofence
    watch = ", ".join(f"{k} {v:g} s" for k, v in sf.watchdog_s.items()) or "none"
    bb = ", ".join(f"{k}: {v.type}" + (f" = {v.value!r}" if v.value is not None and v.type not in ("pose", "point") else "")
                   for k, v in mission.blackboard.items()) or "none"
    return [
        f"rates: tree {r.tree_hz:g} Hz, vehicle {r.vehicle_hz:g} Hz, arm {r.arm_hz:g} Hz",
        f"safety: depth <= {sf.max_depth_m:g} m, altitude >= {sf.min_altitude_m:g} m, duration <= {sf.max_duration_s:g} s, "
        f"geofence N {g.north_m[0]:g}..{g.north_m[1]:g} E {g.east_m[0]:g}..{g.east_m[1]:g} D {g.down_m[0]:g}..{g.down_m[1]:g} m",
        f"watchdogs: {watch}",
        f"blackboard: {bb}",
    ]
