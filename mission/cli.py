"""The ``maris`` command line.

Subcommands live one per module in :mod:`mission.commands`. Each module
defines ``register(subparsers)``, which adds its parser and sets
``func=<callable(args) -> int>`` as a default. Modules must keep their
top-level imports light (no numpy/pinocchio at import time) so that
``maris --help`` stays fast; heavy imports go inside the command function.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys
from importlib import metadata

from mission import commands as _commands_pkg


def _version() -> str:
    try:
        return metadata.version("maris-uvms")
    except metadata.PackageNotFoundError:  # running from a source tree
        return "0.0.0+unknown"


def build_parser() -> argparse.ArgumentParser:
    """Build the top-level parser with every subcommand found in mission.commands."""
    parser = argparse.ArgumentParser(
        prog="maris",
        description=(
            "Mission supervisor and iCAT kinematic control for underwater "
            "vehicle-manipulator systems: validate missions, dry-run them on the "
            "simulator, run them on real devices, and study the logs."
        ),
    )
    parser.add_argument("--version", action="version", version=f"maris {_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for info in sorted(pkgutil.iter_modules(_commands_pkg.__path__), key=lambda m: m.name):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{_commands_pkg.__name__}.{info.name}")
        module.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``maris`` console script; returns the process exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    from mission.runtime.pylog import install_terminal_logging

    install_terminal_logging()  # library warnings: one line each, once (runs also log them as events)
    func = getattr(args, "func", None)
    if func is None:
        parser.print_help()
        return 2
    try:
        return int(func(args) or 0)
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
