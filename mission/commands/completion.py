"""``maris completion {bash,zsh,fish}``: the shell code for tab completion.

Completion is argcomplete's: the shell asks ``maris`` itself, so subcommands,
options, shipped mission names and scenario names complete. Enable it with
``eval "$(maris completion bash)"`` in ``~/.bashrc`` (``zsh``: the same in
``~/.zshrc``; fish: ``maris completion fish | source`` in
``~/.config/fish/config.fish``).
"""

from __future__ import annotations

import argparse
import sys

# Imports inside the functions below are deliberate: shell completion (argcomplete) builds
# the parser on every Tab, so a command loads its heavy modules only when it runs.

SHELLS = ("bash", "zsh", "fish")


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "completion",
        help="print the shell code for tab completion (bash, zsh, fish)",
        description="Print shell code that enables tab completion of maris. bash/zsh: add "
        'eval "$(maris completion bash)" to ~/.bashrc (~/.zshrc); fish: '
        "`maris completion fish | source` in ~/.config/fish/config.fish.",
    )
    p.add_argument("shell", choices=SHELLS, help="your shell")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    try:
        import argcomplete
    except ImportError:
        print("error: shell completion needs the argcomplete package (pip install argcomplete)", file=sys.stderr)
        return 2
    sys.stdout.write(argcomplete.shellcode(["maris"], shell=args.shell))
    return 0
