"""``python -m sim_backend``: list, check and show simulator scenarios.

python -m sim_backend list                 # shipped scenarios and their descriptions
python -m sim_backend check FILE_OR_NAME   # validate; errors as file:line:column: field: message
python -m sim_backend show NAME [--seed N] [--set key=value ...]   # the values one run would use
"""

from __future__ import annotations

import argparse
import sys

from maris_common.yamlsrc import ConfigError

from .scenario import Choice, Range, available_scenarios, load_scenario, sample_values


def _overrides(items: list[str]) -> dict[str, str]:
    out = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep:
            raise SystemExit(f"--set expects key=value, got {item!r}")
        out[key.strip()] = value
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m sim_backend", description="List, check and show simulator scenarios.")
    sub = ap.add_subparsers(dest="cmd", required=True)
    sub.add_parser("list", help="shipped scenarios")
    c = sub.add_parser("check", help="validate a scenario file or name")
    c.add_argument("scenario")
    c.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    s = sub.add_parser("show", help="print every parameter (ranges, and the values drawn for --seed)")
    s.add_argument("scenario")
    s.add_argument("--seed", type=int, default=None)
    s.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = ap.parse_args(argv)
    try:
        if args.cmd == "list":
            for name in available_scenarios():
                print(f"{name:16s} {load_scenario(name)['description']}")
            return 0
        sc = load_scenario(args.scenario, _overrides(args.set))
        if args.cmd == "check":
            print(f"{sc.source}: ok ({'randomized' if sc.randomized else 'fixed'})")
            return 0
        drawn = sample_values(sc, args.seed) if args.seed is not None else None
        for key in sorted(sc.values):
            v = sc.values[key]
            if isinstance(v, Range):
                text = f"uniform [{v.lo:g}, {v.hi:g}]"
            elif isinstance(v, Choice):
                text = f"one of {', '.join(map(str, v.options))}"
            else:
                text = repr(v)
            if drawn is not None and isinstance(v, (Range, Choice)):
                text += f"  -> seed {args.seed}: {drawn[key]!r}"
            print(f"{key} = {text}")
        return 0
    except ConfigError as exc:
        print(exc, file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
