"""``maris watch [URL]``: the behaviour tree of a live run, in the terminal.

Connects to the Foxglove WebSocket server of ``maris sim/run --live`` (as any
Foxglove client would: ``foxglove.websocket.v1``), subscribes to ``/tree`` and
``/supervisor/state`` and redraws the tree in py_trees' display style with
status colours each time it changes (the server sends the latest tree at once,
so joining mid-run shows the current state). Ctrl-C leaves.
"""

from __future__ import annotations

import argparse
import json
import struct
import sys

# Imports inside the functions below are deliberate: shell completion (argcomplete) builds
# the parser on every Tab, so a command loads its heavy modules only when it runs.


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "watch",
        help="watch the behaviour tree of a live run (maris sim/run --live)",
        description=__doc__.split("\n\n")[1],
    )
    p.add_argument(
        "url",
        nargs="?",
        default="ws://127.0.0.1:8765",
        help="the run's live server (default ws://127.0.0.1:8765; add /?token=... when it needs one)",
    )
    p.add_argument("--once", action="store_true", help="print the current tree and exit")
    p.add_argument("--no-colour", "--no-color", dest="colour", action="store_false", help="no ANSI colours")
    p.set_defaults(func=run_watch)


def run_watch(args: argparse.Namespace) -> int:
    try:
        from websockets.exceptions import InvalidStatus, WebSocketException
        from websockets.sync.client import connect
        from websockets.typing import Subprotocol
    except ImportError:
        print("error: maris watch needs the websockets package: pip install 'maris-uvms[live]'", file=sys.stderr)
        return 2
    from mission.logs.treeview import render_lines

    tty = sys.stdout.isatty()
    colour = args.colour and tty
    try:
        ws = connect(args.url, subprotocols=[Subprotocol("foxglove.websocket.v1")], open_timeout=10)
    except InvalidStatus as exc:
        code = exc.response.status_code
        why = "wrong or missing access token (add /?token=...)" if code == 401 else f"HTTP {code}"
        print(f"error: {args.url} refused the connection: {why}", file=sys.stderr)
        return 2
    except (OSError, WebSocketException, TimeoutError) as exc:
        print(f"error: cannot connect to {args.url}: {exc} (is a run with --live going?)", file=sys.stderr)
        return 2
    state = "?"
    subs: dict[int, str] = {}
    try:
        with ws:
            for frame in ws:
                if isinstance(frame, str):
                    msg = json.loads(frame)
                    if msg.get("op") == "advertise":
                        wanted = [c for c in msg["channels"] if c["topic"] in ("/tree", "/supervisor/state")]
                        for c in wanted:
                            subs[c["id"]] = c["topic"]
                        ws.send(
                            json.dumps(
                                {
                                    "op": "subscribe",
                                    "subscriptions": [{"id": c["id"], "channelId": c["id"]} for c in wanted],
                                }
                            )
                        )
                    continue
                if frame[0] != 1:
                    continue
                sub_id, _ns = struct.unpack_from("<IQ", frame, 1)
                msg = json.loads(frame[13:])
                if subs.get(sub_id) == "/supervisor/state":
                    state = msg.get("state", "?")
                    continue
                lines = [
                    f"t={msg['t']:8.2f} s  supervisor {state}  running leaf: {msg.get('tip') or '-'}",
                    *render_lines(msg.get("nodes") or [], colour=colour),
                ]
                text = "\n".join(lines)
                sys.stdout.write(("\x1b[2J\x1b[H" + text + "\n") if tty and not args.once else text + "\n\n")
                sys.stdout.flush()
                if args.once:
                    return 0
    except KeyboardInterrupt:
        return 0
    except WebSocketException:
        pass
    print("the run ended (server closed)", file=sys.stderr)
    return 0
