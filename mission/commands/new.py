"""``maris new FILE [--from TEMPLATE] [--force]``: start a mission from a template.

Templates: ``minimal`` (go to a point, hold, surface; the default) and every
shipped mission by name (``maris_pipe_recovery``, ``survey_only``, ...). The
copy gets ``name:`` from FILE's name, is validated, and the next commands are
printed. An existing FILE is never overwritten without ``--force``.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

from mission.commands._common import SHIPPED_MISSIONS, print_issues, shipped_missions

# Imports inside the functions below are deliberate: shell completion (argcomplete) builds
# the parser on every Tab, so a command loads its heavy modules only when it runs.

TEMPLATES_DIR = Path(__file__).resolve().parents[1] / "templates"


def templates() -> dict[str, Path]:
    """Template name -> file: the built-in ones, then the shipped missions."""

    out = {p.stem: p for p in sorted(TEMPLATES_DIR.glob("*.yaml"))}
    for name in shipped_missions():
        out.setdefault(name, SHIPPED_MISSIONS / f"{name}.yaml")
    return out


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "new",
        help="write a new mission file from a template",
        description="Write a new mission file from a template (a commented minimal mission, "
        "or a copy of a shipped mission), named after the file, and validate it.",
    )
    p.add_argument("file", help="the mission file to write, e.g. missions/dock_check.yaml")
    p.add_argument(
        "--from",
        dest="template",
        default="minimal",
        metavar="TEMPLATE",
        help="template: minimal (default) or a shipped mission's name; --list shows them",
    )
    p.add_argument("--list", action="store_true", help="list the templates and exit")
    p.add_argument("--force", action="store_true", help="overwrite FILE if it exists")
    p.set_defaults(func=run)


def mission_name(path: Path) -> str:
    """A mission name from a file name: letters, digits and underscores."""
    name = re.sub(r"\W+", "_", path.stem).strip("_")
    return name or "new_mission"


def run(args: argparse.Namespace) -> int:
    from maris_common.yamlsrc import ConfigError, suggest
    from mission.loader import load_mission

    available = templates()
    if args.list:
        for name, path in available.items():
            print(f"{name:<24} {path}")
        return 0
    source = available.get(args.template)
    if source is None:
        print(
            f"error: unknown template `{args.template}`{suggest(args.template, available)}; "
            f"templates: {', '.join(available)}",
            file=sys.stderr,
        )
        return 2
    target = Path(args.file)
    if target.suffix not in (".yaml", ".yml"):
        target = target.with_name(target.name + ".yaml")
    if target.exists() and not args.force:
        print(f"error: {target} exists; choose another name or add --force", file=sys.stderr)
        return 2
    name = mission_name(target)
    text, n = re.subn(r"(?m)^name: .*$", f"name: {name}", source.read_text(encoding="utf-8"), count=1)
    if not n:
        text = f"name: {name}\n" + text
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(text, encoding="utf-8")
    except OSError as exc:
        print(f"error: cannot write {target}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    try:
        mission = load_mission(target)
    except ConfigError as exc:  # e.g. a model or actions file relative to the template's folder
        print_issues(exc.issues)
        print(
            f"wrote {target} from `{args.template}`, but it does not validate here: fix the problems above",
            file=sys.stderr,
        )
        return 1
    print(f"wrote {target}: mission `{mission.name}` from the `{args.template}` template, valid")
    print(f"next: edit it (docs/missions.md), then  maris validate {target}  and  maris sim {target}")
    return 0
