"""``maris schema [--out FILE]``: the JSON Schema of the mission format, for
editors (completion and checks while typing). Generated from the same field
table the loader reads (:mod:`mission.format`); ``docs/mission.schema.json``
is the shipped copy. See :mod:`mission.jsonschema`."""

from __future__ import annotations

import argparse
import sys

# Imports inside the functions below are deliberate: shell completion (argcomplete) builds
# the parser on every Tab, so a command loads its heavy modules only when it runs.


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "schema",
        help="print the JSON Schema of the mission format (for editors)",
        description="Print the JSON Schema (draft-07) of mission files. In an editor with the "
        "YAML language server, put `# yaml-language-server: $schema=PATH` on a mission's first line.",
    )
    p.add_argument("--out", metavar="FILE", help="write it to FILE instead of stdout")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from mission.jsonschema import schema_text

    text = schema_text()
    if not args.out:
        sys.stdout.write(text)
        return 0
    try:
        with open(args.out, "w", encoding="utf-8") as fh:
            fh.write(text)
    except OSError as exc:
        print(f"error: cannot write {args.out}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    print(f"wrote {args.out}")
    return 0
