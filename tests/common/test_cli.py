"""The `maris` entry point: help, version, and fast start-up."""

from __future__ import annotations

import subprocess
import sys

from mission.cli import build_parser, main


def test_version_flag_prints_package_version(capsys):
    try:
        main(["--version"])
    except SystemExit as exc:
        assert exc.code == 0
    out = capsys.readouterr().out
    assert out.startswith("maris ")
    assert out.strip().split()[1][0].isdigit()


def test_no_command_prints_help_and_fails(capsys):
    assert main([]) == 2
    assert "usage: maris" in capsys.readouterr().out


def test_every_subcommand_has_help():
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    for name, subparser in sub.choices.items():
        text = subparser.format_help()
        assert name in text


def test_help_does_not_import_heavy_modules():
    code = (
        "import sys\n"
        "from mission.cli import build_parser\n"
        "build_parser().format_help()\n"
        "heavy = [m for m in ('pinocchio', 'matplotlib', 'numpy', 'can', 'pymavlink') if m in sys.modules]\n"
        "print(','.join(heavy))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == "", f"`maris --help` imports heavy modules: {out}"
