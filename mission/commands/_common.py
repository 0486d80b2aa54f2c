"""Small helpers shared by the ``maris`` commands: missions by name, colour,
issue printing, JSON output. Light imports only (``maris --help`` stays fast).
"""

from __future__ import annotations

import glob
import importlib.util
import json
import os
import sys
from collections.abc import Iterable
from dataclasses import asdict, is_dataclass
from pathlib import Path
from typing import Any, TextIO

#: The shipped missions (``missions/`` of the source tree the package runs from).
SHIPPED_MISSIONS = Path(__file__).resolve().parents[2] / "missions"

# --------------------------------------------------------------------------- missions by name


def shipped_missions() -> list[str]:
    """Names (file stems) of the shipped missions, sorted."""
    if not SHIPPED_MISSIONS.is_dir():
        return []
    return sorted(p.stem for p in SHIPPED_MISSIONS.glob("*.yaml"))


def resolve_mission(arg: str) -> str:
    """The mission file meant by ``arg``: the path itself when it exists, else
    (for a bare name such as ``survey_only``) ``missions/NAME.yaml`` in the
    current folder, else the shipped mission of that name. Unknown names are
    returned unchanged: the loader then reports the missing file."""
    p = Path(arg)
    if p.exists() or os.sep in arg or "/" in arg:
        return arg
    stem = arg[:-5] if arg.endswith(".yaml") else arg
    for candidate in (Path("missions") / f"{stem}.yaml", SHIPPED_MISSIONS / f"{stem}.yaml"):
        if candidate.is_file():
            return str(candidate)
    return arg


def not_found_hint(arg: str) -> str:
    """A line naming the shipped missions, for a mission argument that is no file."""
    if Path(arg).exists():
        return ""
    names = shipped_missions()
    return f"{arg}: no such file, and no shipped mission of that name (shipped: {', '.join(names) or 'none'})"


# --------------------------------------------------------------------------- colour

#: ``auto`` (colour on a terminal, unless NO_COLOR is set or TERM=dumb), ``always`` or ``never``;
#: set by ``maris --color``.
COLOUR_MODE = "auto"

_CODES = {"red": "31", "green": "32", "yellow": "33", "blue": "34", "bold": "1", "dim": "2"}


def use_colour(stream: TextIO) -> bool:
    """Whether to colour what goes to ``stream`` (https://no-color.org: any non-empty NO_COLOR turns it off)."""
    if COLOUR_MODE == "never":
        return False
    if COLOUR_MODE == "always":
        return True
    if os.environ.get("NO_COLOR") or os.environ.get("TERM") == "dumb":
        return False
    try:
        return stream.isatty()
    except (AttributeError, ValueError):
        return False


def paint(text: str, style: str, stream: TextIO | None = None) -> str:
    """``text`` wrapped in the ANSI codes of ``style`` (``red``, ``bold yellow``...) when colour is on."""
    if not use_colour(stream or sys.stdout):
        return text
    codes = ";".join(_CODES[s] for s in style.split() if s in _CODES)
    return f"\033[{codes}m{text}\033[0m" if codes else text


OUTCOME_STYLE = {"succeeded": "bold green", "failed": "bold red", "aborted": "bold yellow"}


def format_issue(issue: Any, stream: TextIO) -> str:
    """``file:line:column: [warning:] field: message`` with the place in bold and
    warnings in yellow, errors in red (when colour is on)."""
    text = str(issue)
    where = str(issue.mark)
    rest = text[len(where) :]
    if issue.severity == "warning":
        rest = rest.replace(" warning:", " " + paint("warning:", "bold yellow", stream), 1)
        return paint(where, "bold", stream) + rest
    return paint(where, "bold red", stream) + rest


def print_issues(issues: Iterable[Any], stream: TextIO | None = None) -> None:
    stream = stream or sys.stderr
    for issue in issues:
        print(format_issue(issue, stream), file=stream)


# --------------------------------------------------------------------------- JSON


def to_jsonable(obj: Any) -> Any:
    """Plain JSON values from dataclasses, numpy values, tuples, paths."""

    if is_dataclass(obj) and not isinstance(obj, type):
        return to_jsonable(asdict(obj))
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple, set)):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, float):
        return obj if obj == obj and obj not in (float("inf"), float("-inf")) else None
    if obj is None or isinstance(obj, (str, int, bool)):
        return obj
    if hasattr(obj, "tolist"):
        return to_jsonable(obj.tolist())
    if hasattr(obj, "item"):
        return to_jsonable(obj.item())
    return str(obj)


def print_json(obj: Any, stream: TextIO | None = None) -> None:
    """One JSON document (indented), non-finite numbers as null."""
    print(json.dumps(to_jsonable(obj), indent=2), file=stream or sys.stdout, flush=True)


# --------------------------------------------------------------------------- shell completion


def mission_completer(prefix: str = "", **_: Any) -> list[str]:
    """argcomplete: shipped mission names and YAML files / folders matching ``prefix``."""

    out = [n for n in shipped_missions() if n.startswith(prefix)]
    for p in glob.glob(prefix + "*"):
        if os.path.isdir(p):
            out.append(p + os.sep)
        elif p.endswith((".yaml", ".yml")):
            out.append(p)
    return out


def scenario_completer(prefix: str = "", **_: Any) -> list[str]:
    """argcomplete: shipped scenario names (read from the folder, without importing the simulator)."""

    spec = importlib.util.find_spec("sim_backend")
    names: list[str] = []
    for folder in (spec.submodule_search_locations or []) if spec else []:
        names += [p.stem for p in (Path(folder) / "scenarios").glob("*.yaml")]
    return sorted(n for n in names if n.startswith(prefix))


def mission_argument(parser: Any, nargs: Any = None) -> None:
    """The MISSION positional of validate/show/sim/run: a file or a shipped mission's name."""
    kw = {"nargs": nargs} if nargs else {}
    action = parser.add_argument(
        "mission", help="mission YAML file, or the name of a shipped mission (e.g. survey_only)", **kw
    )
    action.completer = mission_completer
