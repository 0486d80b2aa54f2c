"""The run log and the live server in the real Foxglove Studio 1.48 web app
(headless Chromium): the reference log loads with zero problems and, with the
shipped layout, its 3D panel shows the vehicle and the arm at the seeked time;
connected live, Studio joins late (latched values), and its Pause and Abort
buttons stop the run, which logs who asked. Skipped, with the reason, where
Chromium or the app is not installed (`make viewer` installs them).

Screenshots go to ``$MARIS_VIEWER_OUT`` (default: the test's tmp folder).
"""

from __future__ import annotations

import os
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from mission.runtime.options import RunHooks, RunOptions, RunTarget

sys.path.insert(0, str(Path(__file__).resolve().parent))
import studio  # noqa: E402

pytestmark = [
    pytest.mark.viewer,
    pytest.mark.slow,
    pytest.mark.skipif(studio.missing() is not None, reason=f"Foxglove viewer: {studio.missing()}"),
]

ROOT = Path(__file__).resolve().parents[2]
LAYOUT = ROOT / "mission" / "logs" / "layouts" / "maris.json"


def _out(tmp_path: Path) -> Path:
    out = Path(os.environ.get("MARIS_VIEWER_OUT", tmp_path))
    out.mkdir(parents=True, exist_ok=True)
    return out


def _hull_pixels(png: Path, box: tuple[int, int, int, int]) -> int:
    """Pixels of the see-through yellow hull inside ``box`` = (x0, y0, x1, y1)."""
    import matplotlib.image as mpimg

    a = mpimg.imread(str(png))[..., :3]
    x0, y0, x1, y1 = box
    r = a[y0:y1, x0:x1]
    yellow = (r[..., 0] > 0.8) & (r[..., 1] > 0.6) & (r[..., 2] < 0.6) & (r[..., 0] - r[..., 2] > 0.35)
    return int(yellow.sum())


def test_reference_log_loads_with_zero_problems_and_3d_shows_the_uvms(tmp_path):
    from mission.runtime.api import run_mission

    log = tmp_path / "reference.mcap"
    result = run_mission(
        RunTarget(ROOT / "missions" / "maris_pipe_recovery.yaml", scenario="pool_fixed", seed=1),
        RunOptions(log_path=log),
    )
    assert result.succeeded
    png = _out(tmp_path) / "reference_t25.png"
    page = studio.open_file(log, png, LAYOUT, seek=25.0)
    assert page["returncode"] == 0, page.get("stderr")
    text = page["state"]["text"].replace("\xa0", " ")
    assert studio.problem_count(text) == 0
    assert "foxglove.FrameTransforms" in text and "foxglove.SceneUpdate" in text
    assert "Pipe recovery" in text  # the tree table
    # the Log panel at t = 25 s: the grasp action's start, or its next event (target acquired)
    assert "action grasp started" in text or "action grasp: fresh detection" in text
    assert not page["exceptions"]
    # the 3D panel (left of the layout, right of the sidebar) shows the hull; WebGL in
    # software on a loaded 2-core machine can draw after the screenshot: one more look,
    # with a longer settle, before concluding that the panel is empty
    box = (430, 40, 1060, 550)
    if _hull_pixels(png, box) == 0:
        png = _out(tmp_path) / "reference_t25_again.png"
        assert studio.open_file(log, png, LAYOUT, seek=25.0, settle=30.0)["returncode"] == 0
    assert _hull_pixels(png, box) > 1500, f"no vehicle in the 3D panel: see {png}"


def test_studio_connected_live_joins_late_pauses_and_aborts(tmp_path):
    from mission.logs.live import LiveServer
    from mission.logs.reader import read_log
    from mission.runtime.api import run_mission
    from mission.runtime.operator import CommandQueue

    queue = CommandQueue()
    server = LiveServer(port=0, commands=queue)
    release = threading.Event()
    started = threading.Event()

    def hold(now: float) -> None:  # at 2 s the run waits (once) until Studio has pressed its buttons
        if now >= 2.0 and not started.is_set():
            started.set()
            release.wait(120)

    result: dict = {}
    log = tmp_path / "live.mcap"
    run = threading.Thread(
        target=lambda: result.update(
            r=run_mission(
                RunTarget(ROOT / "missions" / "maris_pipe_recovery.yaml", seed=1),
                RunOptions(log_path=log),
                RunHooks(commands=queue, pollers=[hold], live=server),
            )
        )
    )
    run.start()
    viewer = None
    try:
        assert started.wait(60)
        viewer = studio.LiveStudio(server.url, LAYOUT)  # joins after the start was written
        viewer.wait_for(lambda v: v.button_enabled("Pause"), what="the Publish panels to be enabled")
        viewer.wait_for(lambda v: "Pipe recovery" in v.text().replace("\xa0", " "), what="the latched tree")
        time.sleep(3)  # let the 3D panel draw the latched scene
        png = _out(tmp_path) / "live_joined.png"
        viewer.screenshot(png)
        assert _hull_pixels(png, (430, 40, 1060, 550)) > 1500, f"no vehicle in the live 3D panel: see {png}"
        viewer.click("Pause")
        deadline = time.monotonic() + 20
        while not any(c == "pause" for c, _ in list(queue._q)) and time.monotonic() < deadline:
            time.sleep(0.1)
        viewer.click("Abort")
        time.sleep(1.0)
    finally:
        release.set()
        run.join(180)
        if viewer is not None:
            viewer.close()
        server.close()
    r = result["r"]
    assert r.outcome == "aborted" and r.failure_cause.startswith("operator abort (Foxglove client 127.0.0.1:")
    events = read_log(log).messages("/events")
    operator = [(e["fields"]["command"], e["fields"]["source"]) for e in events if e["kind"] == "operator"]
    assert [c for c, _ in operator] == ["pause", "abort"]
    states = [m["state"] for m in read_log(log).messages("/supervisor/state")]
    assert states[:4] == ["preflight", "running", "paused", "aborting"]
    assert np.isfinite(r.duration_s)
