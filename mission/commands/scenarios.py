"""``maris scenarios list`` / ``maris scenarios show NAME [--seed N] [--set K=V]``:
the simulator's scenarios, as YAML.

``list`` prints each shipped scenario with its description. ``show`` prints
every parameter of one scenario (after ``extends:`` and ``--set``) as a YAML
document in the scenario files' own syntax (``{min: a, max: b}`` for a value
drawn from the seed, ``{choice: [...]}`` for a pick); with ``--seed`` the
values one run with that seed would use. The output is valid YAML that can be
saved as a scenario file.
"""

from __future__ import annotations

import argparse
import sys

from mission.commands._common import print_issues

# Imports inside the functions below are deliberate: shell completion (argcomplete) builds
# the parser on every Tab, so a command loads its heavy modules only when it runs.


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "scenarios",
        help="list the simulator's scenarios, or show one as YAML",
        description="List the simulator's scenarios or print one (every parameter) as YAML.",
    )
    sub = p.add_subparsers(dest="scenarios_command", metavar="{list,show}")
    sub.add_parser("list", help="shipped scenarios and their descriptions").set_defaults(func=run_list)
    s = sub.add_parser("show", help="every parameter of a scenario, as YAML")
    s.add_argument("scenario", help="scenario name (see `maris scenarios list`) or YAML path")
    s.add_argument("--seed", type=int, default=None, help="print the values a run with this seed would draw")
    s.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="override a parameter (repeatable)")
    s.set_defaults(func=run_show)
    p.set_defaults(func=lambda args: (p.print_help(), 2)[1])


def run_list(args: argparse.Namespace) -> int:
    from maris_common.yamlsrc import ConfigError
    from sim_backend.scenario import available_scenarios, load_scenario

    for name in available_scenarios():
        try:
            description = load_scenario(name)["description"]
        except ConfigError as exc:
            description = f"(broken: {exc.issues[0] if exc.issues else exc})"
        print(f"{name:<16} {description}")
    return 0


def scenario_document(scenario, drawn: dict | None = None) -> dict:
    """The scenario's values as nested mappings (dotted keys split), in file syntax."""
    from sim_backend.scenario import Choice, Range

    doc: dict = {}
    for key in sorted(scenario.values, key=lambda k: (k != "description", k)):  # description first
        value = scenario.values[key] if drawn is None or key not in drawn else drawn[key]
        if isinstance(value, Range):
            value = {"min": value.lo, "max": value.hi}
        elif isinstance(value, Choice):
            value = {"choice": list(value.options)}
        parts = key.split(".")
        node = doc
        for part in parts[:-1]:
            node = node.setdefault(part, {})
        node[parts[-1]] = _plain(value)
    return doc


def _plain(value):
    """Tuples, numpy values -> lists and Python scalars (for yaml.safe_dump)."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if hasattr(value, "tolist"):
        return _plain(value.tolist())
    return value


def run_show(args: argparse.Namespace) -> int:
    import yaml

    from maris_common.yamlsrc import ConfigError
    from mission.commands.sim import parse_sets
    from sim_backend.scenario import load_scenario, sample_values

    try:
        scenario = load_scenario(args.scenario, parse_sets(args.set))
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except ConfigError as exc:
        print_issues(exc.issues)
        return 1
    drawn = sample_values(scenario, args.seed) if args.seed is not None else None
    doc = scenario_document(scenario, drawn)
    header = f"# scenario {scenario.name} ({scenario.source})"
    if drawn is not None:
        header += f", values drawn for seed {args.seed}"
    elif scenario.randomized:
        header += "; {min, max} and {choice} values are drawn from each run's seed"
    print(header)
    print(yaml.safe_dump(doc, sort_keys=False, default_flow_style=None, width=100), end="")
    return 0
