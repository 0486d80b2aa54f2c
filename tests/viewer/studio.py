"""Drive the real Foxglove Studio 1.48 web app in headless Chromium for the tests.

The viewer tool lives outside the repository (``../shared/tools/mcap-viewer``,
or ``$MCAP_VIEWER_DIR``): ``open_mcap.sh`` opens a file and takes a screenshot;
for a live connection this module reuses that tool's pieces (its Chromium
launcher over the DevTools pipe and its static HTTP server) and points the app
at a WebSocket URL instead of a file. ``make viewer`` installs Chromium and the
app; :func:`missing` says why the tests must be skipped when they are absent.
"""

from __future__ import annotations

import base64
import importlib.util
import json
import os
import shutil
import subprocess
import tempfile
import threading
import time
import urllib.parse
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def tool_dir() -> Path:
    return Path(os.environ.get("MCAP_VIEWER_DIR", ROOT.parent / "shared" / "tools" / "mcap-viewer"))


def app_dir() -> Path:
    return Path(os.environ.get("MCAP_VIEWER_APP_DIR", "/opt/foxglove-studio-web"))


def missing() -> str | None:
    """Why the viewer cannot run here (None: it can)."""
    if not (tool_dir() / "open_mcap.py").is_file():
        return f"viewer tool not found at {tool_dir()} (set MCAP_VIEWER_DIR)"
    if shutil.which(os.environ.get("MCAP_VIEWER_CHROMIUM", "chromium")) is None:
        return "chromium not installed: run `make viewer`"
    if not (app_dir() / "assets" / "index.js").is_file():
        return f"Foxglove Studio 1.48 web app not installed at {app_dir()}: run `make viewer`"
    return None


def open_file(mcap: Path, png: Path, layout: Path, *, seek: float, settle: float = 10.0) -> dict:
    """``open_mcap.sh`` on a file: returns its page dump (text, console) and exit code."""
    dump = png.with_suffix(".json")
    proc = subprocess.run(
        [
            str(tool_dir() / "open_mcap.sh"),
            str(mcap),
            str(png),
            str(layout),
            "--seek",
            str(seek),
            "--settle",
            str(settle),
            "--wait",
            "60",
            "--dump-text",
            str(dump),
        ],
        capture_output=True,
        text=True,
        timeout=240,
    )
    out = json.loads(dump.read_text()) if dump.exists() else {}
    out["returncode"] = proc.returncode
    out["stderr"] = proc.stderr
    return out


def problem_count(page_text: str) -> int:
    """The number the sidebar shows after "Problems" (0 when it shows none)."""
    lines = page_text.splitlines()
    for i, line in enumerate(lines):
        if line.strip() == "Problems" and i + 1 < len(lines):
            nxt = lines[i + 1].strip()
            return int(nxt) if nxt.isdigit() else 0
    raise AssertionError("no Problems tab in the page (is the sidebar shown?)")


def _load_tool():
    spec = importlib.util.spec_from_file_location("open_mcap", tool_dir() / "open_mcap.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


class LiveStudio:
    """Studio connected to a Foxglove WebSocket server (``ws_url``) with ``layout``."""

    def __init__(self, ws_url: str, layout: Path, *, width: int = 1600, height: int = 900) -> None:
        tool = _load_tool()
        tool.Handler.app_dir = str(app_dir())
        tool.Handler.routes = {"/__data/layout.json": str(layout)}
        self._srv = tool.Server(("127.0.0.1", 0), tool.Handler)
        threading.Thread(target=self._srv.serve_forever, daemon=True).start()
        base = f"http://127.0.0.1:{self._srv.server_address[1]}"
        query = {
            "ds": "foxglove-websocket",
            "ds.url": ws_url,
            "layoutId": "viewer-layout",
            "viewerLayout": "/__data/layout.json",
            "viewerTheme": "light",
            "viewerSidebar": "connection",
        }
        self._profile = tempfile.mkdtemp(prefix="maris_studio_")
        chromium = shutil.which(os.environ.get("MCAP_VIEWER_CHROMIUM", "chromium"))
        self._proc, self._cdp = tool.launch_chromium(chromium, width, height, self._profile, [])
        target = self._cdp.send("Target.createTarget", {"url": "about:blank"})["targetId"]
        self._sid = self._cdp.send("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
        for method in ("Page.enable", "Runtime.enable"):
            self._cdp.send(method, session=self._sid)
        self._cdp.send(
            "Emulation.setDeviceMetricsOverride",
            {"width": width, "height": height, "deviceScaleFactor": 1, "mobile": False},
            session=self._sid,
        )
        self._cdp.send(
            "Page.navigate", {"url": f"{base}/index.html?" + urllib.parse.urlencode(query)}, session=self._sid
        )

    def eval(self, expression: str):
        r = self._cdp.send("Runtime.evaluate", {"expression": expression, "returnByValue": True}, session=self._sid)
        return r.get("result", {}).get("value")

    def text(self) -> str:
        return self.eval("document.body ? document.body.innerText : ''") or ""

    def wait_for(self, predicate, timeout: float = 60.0, what: str = "condition") -> None:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            try:
                if predicate(self):
                    return
            except Exception:  # noqa: BLE001 - the page is still booting
                pass
            time.sleep(0.5)
        raise AssertionError(f"viewer: timed out waiting for {what}; page text: {self.text()[:1500]!r}")

    def button_enabled(self, label: str) -> bool:
        return bool(
            self.eval(
                f"[...document.querySelectorAll('button')].some(b => b.innerText.trim() === {json.dumps(label)} && !b.disabled)"
            )
        )

    def click(self, label: str) -> None:
        """Click the (enabled) button showing ``label``, as a user would."""
        box = self.eval(
            f"(() => {{ const b = [...document.querySelectorAll('button')].find(b => b.innerText.trim() === "
            f"{json.dumps(label)} && !b.disabled); if (!b) return null; const r = b.getBoundingClientRect(); "
            f"return [r.x + r.width / 2, r.y + r.height / 2]; }})()"
        )
        assert box, f"no enabled button {label!r}"
        for kind in ("mousePressed", "mouseReleased"):
            self._cdp.send(
                "Input.dispatchMouseEvent",
                {"type": kind, "x": box[0], "y": box[1], "button": "left", "clickCount": 1},
                session=self._sid,
            )

    def rect(self, js: str) -> list[float] | None:
        """``[x, y, width, height]`` of the element the JavaScript expression ``js`` gives (None: none)."""
        return self.eval(
            f"(() => {{ const e = {js}; if (!e) return null; const r = e.getBoundingClientRect(); "
            "return [r.x, r.y, r.width, r.height]; })()"
        )

    def mouse(self, kind: str, x: float, y: float) -> None:
        """One mouse event (``mousePressed``, ``mouseReleased``, ``mouseMoved``) at page pixel (x, y)."""
        event = {"type": kind, "x": x, "y": y, "button": "left" if kind != "mouseMoved" else "none"}
        if kind != "mouseMoved":
            event["clickCount"] = 1
        self._cdp.send("Input.dispatchMouseEvent", event, session=self._sid)

    def click_at(self, x: float, y: float, hold_s: float = 0.0) -> None:
        """Move to, press and release the left button at (x, y), holding it ``hold_s`` s."""
        self.mouse("mouseMoved", x, y)
        self.mouse("mousePressed", x, y)
        if hold_s:
            time.sleep(hold_s)
        self.mouse("mouseReleased", x, y)

    def screenshot(self, path: Path) -> None:
        shot = self._cdp.send("Page.captureScreenshot", {"format": "png"}, session=self._sid, timeout=120)
        Path(path).write_bytes(base64.b64decode(shot["data"]))

    def close(self) -> None:
        try:
            self._cdp.send("Browser.close", timeout=10)
        except Exception:  # noqa: BLE001
            pass
        try:
            self._proc.wait(timeout=15)
        except subprocess.TimeoutExpired:
            self._proc.kill()
            self._proc.wait()
        self._srv.shutdown()
        shutil.rmtree(self._profile, ignore_errors=True)
