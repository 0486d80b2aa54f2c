"""``maris validate MISSION... [--hal CONFIG] [--strict] [--json]``: check
mission files before they run.

Exit 0 and a one-line summary per mission when all are valid; exit 1 and every
problem (``file:line:column: field: message``) otherwise. The safety lint's
warnings (``file:line:column: warning: field: message``) do not fail a mission
unless ``--strict``. ``--json`` prints one JSON document instead (stdout).
Never a traceback for bad input: problems in the HAL config file are reported
the same way. MISSION may be the name of a shipped mission (``survey_only``).
"""

from __future__ import annotations

import argparse
import sys

from mission.commands._common import mission_argument, not_found_hint, paint, print_issues, print_json, resolve_mission

# Imports inside the functions below are deliberate: shell completion (argcomplete) builds
# the parser on every Tab, so a command loads its heavy modules only when it runs.


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "validate",
        help="check a mission file (all errors at once, with file:line:column)",
        description="Load a mission YAML file and run every static check: keys, types, ranges, "
        "references (actions, subtrees, blackboard keys, devices with --hal) and the safety lint "
        "(errors, and warnings that --strict turns into errors).",
    )
    mission_argument(p, nargs="+")
    p.add_argument(
        "--hal", metavar="CONFIG", help="HAL config YAML: also check that the devices the mission needs exist"
    )
    p.add_argument("--strict", action="store_true", help="treat the safety lint's warnings as errors")
    p.add_argument("--json", action="store_true", help="print the results as one JSON document on stdout")
    p.set_defaults(func=run)


def check_one(path: str, hal: str | None, strict: bool) -> dict:
    """The JSON-able result of validating one mission file."""
    from maris_common.yamlsrc import ConfigError
    from mission.loader import load_mission

    resolved = resolve_mission(path)
    out: dict = {"mission": path, "file": resolved}
    try:
        mission = load_mission(resolved, hal_config=hal, strict=strict)
    except ConfigError as exc:
        errors = [i for i in exc.issues if i.severity == "error"]
        strict_warnings = [i for i in exc.issues if i.severity == "warning"]
        out.update(
            valid=False,
            errors=errors,
            warnings=list(exc.warnings) if not strict else strict_warnings,
            hint=not_found_hint(resolved) or None,
        )
        return out
    out.update(
        valid=True,
        name=mission.name,
        errors=[],
        warnings=list(mission.warnings),
        nodes=sum(1 for _ in mission.tree.walk()),
        subtrees=len(mission.subtrees),
    )
    return out


def run(args: argparse.Namespace) -> int:
    results = [check_one(path, args.hal, args.strict) for path in args.mission]
    status = 0 if all(r["valid"] for r in results) else 1
    if args.json:
        print_json(
            {
                "valid": status == 0,
                "strict": args.strict,
                "hal": args.hal,
                "missions": [
                    {
                        **r,
                        "errors": [i.to_dict() for i in r["errors"]],
                        "warnings": [i.to_dict() for i in r["warnings"]],
                    }
                    for r in results
                ],
            }
        )
        return status
    for r in results:
        path = r["file"]
        if not r["valid"]:
            shown = sorted(
                r["errors"] + (r["warnings"] if args.strict else []), key=lambda i: (i.mark.line, i.mark.column)
            )
            print_issues(shown)
            if not args.strict:
                print_issues(r["warnings"])
            n = len(shown)
            more = (
                f" (and {len(r['warnings'])} warning{'s' if len(r['warnings']) != 1 else ''})"
                if r["warnings"] and not args.strict
                else ""
            )
            print(
                r["hint"] or paint(f"{path}: {n} problem{'s' if n != 1 else ''} found{more}", "red", sys.stderr),
                file=sys.stderr,
            )
            continue
        print_issues(r["warnings"])
        w = len(r["warnings"])
        hal = f", devices checked against {args.hal}" if args.hal else ""
        warn = f"; {w} warning{'s' if w != 1 else ''}" if w else ""
        print(
            paint(f"{path}: mission `{r['name']}` is valid", "green") + f" ({r['nodes']} nodes in the main tree, "
            f"{r['subtrees']} subtree{'s' if r['subtrees'] != 1 else ''}, abort path present{hal}){warn}"
        )
    return status
