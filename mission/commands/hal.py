"""``maris hal check CONFIG``: connect to every device of a HAL config and report.

Prints one block per device role: health state, the reason when not OK, and
the driver's diagnostics (NMT and CiA 402 state and heartbeat age per drive,
MAVLink mode / armed / heartbeat age / message rates, DVL and AHRS rates).
Exit status: 0 when every device is usable, 1 when any is missing or faulted,
2 when the config itself is invalid. Imports stay inside the function so
``maris --help`` remains fast.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("hal", help="hardware abstraction layer tools (check devices)")
    sub = p.add_subparsers(dest="hal_command", metavar="HAL_COMMAND")
    chk = sub.add_parser("check", help="connect to every configured device and print its state")
    chk.add_argument("config", help="HAL config YAML (e.g. hal/configs/sim.yaml)")
    chk.add_argument("--wait", type=float, default=6.0,
                     help="seconds to let devices come up before judging (default 6; ends as soon as all are usable)")
    chk.set_defaults(func=run_check)
    p.set_defaults(func=lambda args: (p.print_help(), 2)[1])


def format_info(info: Any, indent: str = "    ") -> list[str]:
    """Diagnostics as ``key: value`` lines; nested dicts and lists of dicts indented."""
    lines: list[str] = []
    if isinstance(info, dict):
        flat = {k: v for k, v in info.items() if not isinstance(v, (dict, list)) or (isinstance(v, dict) and all(not isinstance(x, (dict, list)) for x in v.values()) and len(v) <= 6)}
        if flat:
            lines.append(indent + "  ".join(f"{k}={_fmt(v)}" for k, v in flat.items()))
        for k, v in info.items():
            if k in flat:
                continue
            lines.append(f"{indent}{k}:")
            lines.extend(format_info(v, indent + "  "))
    elif isinstance(info, list):
        for item in info:
            lines.extend(format_info(item, indent))
    else:
        lines.append(indent + _fmt(info))
    return lines


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.3g}"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{k}: {_fmt(x)}" for k, x in v.items()) + "}"
    return str(v)


def run_check(args: argparse.Namespace) -> int:
    import time

    from hal.config import load_hal_config
    from hal.factory import DeviceUnavailable, build_backend
    from maris_common.yamlsrc import ConfigError

    try:
        config = load_hal_config(args.config)
        backend = build_backend(config)
    except ConfigError as exc:
        print(f"invalid HAL config:\n{exc}", file=sys.stderr)
        return 2
    except DeviceUnavailable as exc:
        print(f"FAILED to connect: {exc}", file=sys.stderr)
        return 1
    try:
        try:
            backend.open()
        except Exception as exc:  # noqa: BLE001 - any device may fail its own way; report it, no traceback
            print(f"FAILED to connect: {exc}", file=sys.stderr)
            return 1
        deadline = time.monotonic() + max(0.0, args.wait)
        while True:
            backend.advance(0.05)
            healths = {role: dev.health() for role, dev in backend.devices.by_role().items()}
            if all(h.state.usable for h in healths.values()) or time.monotonic() >= deadline:
                break
        print(f"HAL config {args.config}: {len(healths)} device(s)")
        for role, h in healths.items():
            print(f"{role:14s} {h.state.name:8s} {h.detail}".rstrip())
            for line in format_info(h.info):
                print(line)
        bad = [r for r, h in healths.items() if not h.state.usable]
        print("all devices healthy" if not bad else f"NOT healthy: {', '.join(bad)}")
        return 1 if bad else 0
    finally:
        backend.close()
