# PYTHON_ARGCOMPLETE_OK
"""The ``maris`` command line.

Subcommands live one per module in :mod:`mission.commands`. Each module
defines ``register(subparsers)``, which adds its parser and sets
``func=<callable(args) -> int>`` as a default. Modules must keep their
top-level imports light (no numpy/pinocchio at import time) so that
``maris --help`` and shell completion (argcomplete, ``maris completion``)
stay fast; heavy imports go inside the command function.

Output conventions: colour only on a terminal (``--color``, ``NO_COLOR``);
a closed pipe (``maris show ... | head``) ends the command quietly with exit
code 141, as a process killed by SIGPIPE would.
"""

from __future__ import annotations

import argparse
import importlib
import os
import pkgutil
import sys
from importlib import metadata

from mission import commands as _commands_pkg
from mission.runtime.pylog import install_terminal_logging

# Imports inside the functions below are deliberate: shell completion (argcomplete) builds
# the parser on every Tab, so a command loads its heavy modules only when it runs.


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
    parser.add_argument(
        "--color",
        "--colour",
        dest="color",
        choices=("auto", "always", "never"),
        default="auto",
        help="colour the output: auto (on a terminal, unless NO_COLOR is set), always, never",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for info in sorted(pkgutil.iter_modules(_commands_pkg.__path__), key=lambda m: m.name):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{_commands_pkg.__name__}.{info.name}")
        module.register(sub)
    return parser


#: Exit code after a closed output pipe (128 + SIGPIPE, what a shell reports for `yes | head`).
EXIT_BROKEN_PIPE = 141


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``maris`` console script; returns the process exit code."""
    from mission.commands import _common

    parser = build_parser()
    if argv is None:  # shell completion: answers and exits when called by the shell's hook
        try:
            import argcomplete
        except ImportError:  # pragma: no cover - a dependency, but completion is optional
            pass
        else:
            argcomplete.autocomplete(parser)
    args = parser.parse_args(argv)
    _common.COLOUR_MODE = args.color

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
    except BrokenPipeError:  # `maris show ... | head`: the reader is gone, so is our output
        _silence_stdout()
        return EXIT_BROKEN_PIPE


def _silence_stdout() -> None:
    """Point stdout at /dev/null so the interpreter's final flush cannot fail again."""

    try:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    except (OSError, ValueError):
        pass


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
