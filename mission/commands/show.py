"""``maris show MISSION [--dot FILE] [--png FILE]``: display a mission's trees.

Prints the main tree and the abort tree in the terminal (py_trees' unicode
rendering); ``--dot`` writes a Graphviz file (:mod:`mission.tree_dot`: the two
trees as two clusters), ``--png`` renders it with the graphviz ``dot`` program
when it is installed, else with matplotlib (:mod:`mission.tree_png`). The
safety lint's warnings go to stderr. MISSION may be a shipped mission's name.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys

from mission.commands._common import mission_argument, not_found_hint, print_issues, resolve_mission

# Imports inside the functions below are deliberate: shell completion (argcomplete) builds
# the parser on every Tab, so a command loads its heavy modules only when it runs.


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "show",
        help="print a mission's behaviour tree (or write it as .dot / .png)",
        description="Load a mission and print its behaviour tree and abort tree.",
    )
    mission_argument(p)
    p.add_argument("--dot", metavar="FILE", help="also write the tree as a Graphviz .dot file")
    p.add_argument(
        "--png", metavar="FILE", help="also render the tree to a PNG (graphviz `dot` if installed, else matplotlib)"
    )
    p.add_argument("--ascii", action="store_true", help="plain ASCII instead of unicode symbols")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from maris_common.yamlsrc import ConfigError
    from mission.loader import load_mission

    path = resolve_mission(args.mission)
    try:
        mission = load_mission(path)
    except ConfigError as exc:
        print_issues(exc.issues)
        hint = not_found_hint(path)
        print(hint or f"{path}: not shown, fix the problems above (maris validate)", file=sys.stderr)
        return 1
    print_issues(mission.warnings)

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
    from mission.tree_dot import to_dot

    trees = [("main tree", root), ("abort path", abort)]
    dot_text = to_dot(trees, title=f"mission {mission.name}")
    status = 0
    if args.dot:
        try:
            with open(args.dot, "w", encoding="utf-8") as fh:
                fh.write(dot_text)
            print(f"wrote {args.dot}")
        except OSError as exc:
            print(f"cannot write {args.dot}: {exc}", file=sys.stderr)
            status = 1
    if args.png:
        try:
            dot = shutil.which("dot")
            if dot is not None:
                done = subprocess.run(
                    [dot, "-Tpng", "-o", args.png], input=dot_text, capture_output=True, text=True, timeout=120
                )
                if done.returncode != 0:
                    raise RuntimeError(f"dot failed: {done.stderr.strip()[:300]}")
            else:  # no Graphviz: draw it with matplotlib instead
                from mission.tree_png import write_trees_png

                write_trees_png(trees, args.png, title=f"mission {mission.name}")
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
    bb = (
        ", ".join(
            f"{k}: {v.type}" + (f" = {v.value!r}" if v.value is not None and v.type not in ("pose", "point") else "")
            for k, v in mission.blackboard.items()
        )
        or "none"
    )
    return [
        f"rates: tree {r.tree_hz:g} Hz, vehicle {r.vehicle_hz:g} Hz, arm {r.arm_hz:g} Hz",
        f"safety: depth <= {sf.max_depth_m:g} m, altitude >= {sf.min_altitude_m:g} m, duration <= {sf.max_duration_s:g} s, "
        f"geofence N {g.north_m[0]:g}..{g.north_m[1]:g} E {g.east_m[0]:g}..{g.east_m[1]:g} D {g.down_m[0]:g}..{g.down_m[1]:g} m",
        f"watchdogs: {watch}",
        f"blackboard: {bb}",
    ]
