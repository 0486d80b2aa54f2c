"""An IP camera serving MJPEG over HTTP on 127.0.0.1, as many network cameras do.

    python -m hal.testing.mjpeg_camera --left L_FOLDER --right R_FOLDER --fps 10

Behaves like such a camera: nothing is sent until a client asks (``GET
/left`` or ``GET /right``); the answer is ``multipart/x-mixed-replace`` with
one ``image/jpeg`` part (with ``Content-Length``) per frame, the images of the
folder in name order, looping, at ``--fps``; both paths show the frame of the
same index at the same time (one shared clock, like a triggered pair). A
camera that freezes keeps the connection open and sends nothing.

Prints ``READY <port>``. stdin, one JSON object per line: ``{"cmd": "stall",
"camera": "left"|"right"|"both"}`` (freeze), ``{"cmd": "resume"}``,
``{"cmd": "corrupt", "camera": ..., "n": 2}`` (the next n frames are cut
short, so they do not decode), ``{"cmd": "drop"}`` (close every connection,
like a network cut; new connections work), ``{"cmd": "quit"}``.
"""

from __future__ import annotations

import argparse
import http.server
import json
import os
import socketserver
import sys
import threading
import time
from pathlib import Path

import cv2

SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp")


class State:
    def __init__(self, frames: dict[str, list[bytes]], fps: float):
        self.frames = frames
        self.period = 1.0 / fps
        self.t0 = time.monotonic()
        self.stalled: set[str] = set()
        self.corrupt: dict[str, int] = {"left": 0, "right": 0}
        self.generation = 0  # bumped by "drop": handlers of older generations hang up
        self.lock = threading.Lock()


def load(folder: str) -> list[bytes]:
    out = []
    for p in sorted(Path(folder).iterdir()):
        if p.suffix.lower() in SUFFIXES:
            img = cv2.imread(str(p), cv2.IMREAD_COLOR)
            if img is not None:
                out.append(cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, 95])[1].tobytes())
    if not out:
        raise SystemExit(f"no images in {folder}")
    return out


def make_handler(state: State) -> type[http.server.BaseHTTPRequestHandler]:
    class Handler(http.server.BaseHTTPRequestHandler):
        def do_GET(self) -> None:  # noqa: N802
            cam = self.path.strip("/").split("?")[0].split("/")[0]
            if cam not in state.frames:
                self.send_error(404, "cameras: /left, /right")
                return
            self.send_response(200)
            self.send_header("Content-Type", "multipart/x-mixed-replace; boundary=mjpegframe")
            self.send_header("Cache-Control", "no-cache")
            self.end_headers()
            gen = state.generation
            last = -1
            frames = state.frames[cam]
            try:
                while state.generation == gen:
                    k = int((time.monotonic() - state.t0) / state.period)
                    if k == last or cam in state.stalled:
                        time.sleep(0.005)
                        continue
                    last = k
                    data = frames[k % len(frames)]
                    with state.lock:
                        if state.corrupt[cam] > 0:
                            state.corrupt[cam] -= 1
                            data = data[: len(data) // 3]
                    head = f"--mjpegframe\r\nContent-Type: image/jpeg\r\nContent-Length: {len(data)}\r\n\r\n".encode()
                    self.wfile.write(head + data + b"\r\n")
                    self.wfile.flush()
            except (BrokenPipeError, ConnectionResetError, OSError):
                return

        def log_message(self, *args: object) -> None:
            pass

    return Handler


class Server(socketserver.ThreadingMixIn, http.server.HTTPServer):
    daemon_threads = True
    allow_reuse_address = True


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--left", required=True)
    ap.add_argument("--right", required=True)
    ap.add_argument("--fps", type=float, default=10.0)
    ap.add_argument("--port", type=int, default=0)
    ap.add_argument("--max-runtime", type=float, default=300.0)
    a = ap.parse_args(argv)
    state = State({"left": load(a.left), "right": load(a.right)}, a.fps)
    server = Server(("127.0.0.1", a.port), make_handler(state))
    threading.Thread(target=server.serve_forever, daemon=True).start()
    timer = threading.Timer(a.max_runtime, lambda: os._exit(0))  # never outlive a crashed test
    timer.daemon = True
    timer.start()
    print(f"READY {server.server_address[1]}", flush=True)
    for line in sys.stdin:
        try:
            cmd = json.loads(line)
        except ValueError:
            continue
        which = cmd.get("camera", "both")
        cams = ("left", "right") if which == "both" else (which,)
        if cmd.get("cmd") == "stall":
            state.stalled.update(cams)
        elif cmd.get("cmd") == "resume":
            state.stalled.clear()
        elif cmd.get("cmd") == "corrupt":
            with state.lock:
                for c in cams:
                    state.corrupt[c] += int(cmd.get("n", 1))
        elif cmd.get("cmd") == "drop":
            state.generation += 1
        elif cmd.get("cmd") == "quit":
            break
    server.shutdown()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
