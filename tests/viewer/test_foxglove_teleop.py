"""The operator in the real Foxglove Studio 1.48 web app (headless Chromium), connected
live to a teleop dry run with the shipped teleop layout (``maris_teleop.json``):

* the Teleop panel: its up arrow held down publishes ``geometry_msgs/Twist`` at 10 Hz;
  the run's foxglove input gets them and the vehicle jog follows;
* the 3D panel's click-to-publish: Studio 1.48 publishes only in a ROS profile, which the
  live server announces (``ROS_DISTRO``); a pose clicked (two clicks: place, then aim)
  goes out as ``geometry_msgs/PoseStamped`` in the panel's display frame
  (``vehicle_level``) and becomes the vehicle's goal; a point clicked (after choosing
  "Publish point" from the button's long-press menu) becomes the tool's goal;
* the Publish panels switch modes and hand control back.

Screenshots go to ``$MARIS_VIEWER_OUT`` (default: the test's tmp folder)."""

from __future__ import annotations

import os
import sys
import threading
import time
from pathlib import Path

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
LAYOUT = ROOT / "mission" / "logs" / "layouts" / "maris_teleop.json"
MISSION = """name: studio_teleop
safety:
  max_depth_m: 4.0
  min_altitude_m: 0.5
  max_duration_s: 600
  geofence: {north_m: [0, 25], east_m: [0, 12], down_m: [0, 4]}
tree:
  teleop:
    modes: [vehicle_velocity, vehicle_goal, tool_goal]
    inputs: [foxglove]
    deadman_s: 0.5
    timeout_s: 500
abort:
  action: {run: hold, timeout_s: 10}
"""
PAD_UP = "[...document.querySelectorAll('svg[viewBox=\"0 0 256 256\"] g[role=button]')][0]"
PUBLISH = "document.querySelector('[data-testid=publish-button]')"
CANVAS = "[...document.querySelectorAll('canvas')].sort((a, b) => b.width * b.height - a.width * a.height)[0]"


def _out(tmp_path: Path) -> Path:
    out = Path(os.environ.get("MARIS_VIEWER_OUT", tmp_path))
    out.mkdir(parents=True, exist_ok=True)
    return out


def _centre(r: list[float]) -> tuple[float, float]:
    return r[0] + r[2] / 2, r[1] + r[3] / 2


def _wait(cond, timeout: float, what: str) -> None:
    end = time.monotonic() + timeout
    while not cond():
        assert time.monotonic() < end, f"timed out waiting for {what}"
        time.sleep(0.1)


def test_teleop_panel_and_3d_publish_drive_a_live_run(tmp_path):
    from mission.logs.live import LiveServer
    from mission.logs.reader import read_log
    from mission.runtime.api import run_mission

    mission = tmp_path / "studio_teleop.yaml"
    mission.write_text(MISSION)
    server = LiveServer(port=0)
    release = threading.Event()
    held = threading.Event()
    events: list = []

    def hold(now: float) -> None:  # the run waits (once) until Studio is connected and ready
        if now >= 0.5 and not held.is_set():
            held.set()
            release.wait(180)

    result: dict = {}
    log = tmp_path / "studio_teleop.mcap"
    run = threading.Thread(
        target=lambda: result.update(
            r=run_mission(
                RunTarget(mission, seed=1),
                RunOptions(log_path=log, realtime=True),
                RunHooks(pollers=[hold], live=server, on_event=events.append),
            )
        )
    )
    run.start()
    out = _out(tmp_path)
    viewer = None
    try:
        assert held.wait(60)
        viewer = studio.LiveStudio(server.url, LAYOUT, width=1600, height=1000)
        viewer.wait_for(lambda v: v.rect(PAD_UP) is not None, what="the Teleop panel's pad (publishing allowed)")
        release.set()
        viewer.wait_for(lambda v: v.rect(PUBLISH) is not None, timeout=90, what="the 3D panel's publish button")
        device = server.operator_input
        viewer.screenshot(out / "teleop_connected.png")

        # the Teleop panel: up held for 2 s -> Twist at 10 Hz, the vehicle jogs forward
        received = device.health().info["received"]
        viewer.click_at(*_centre(viewer.rect(PAD_UP)), hold_s=2.0)
        _wait(lambda: device.health().info["received"] >= received + 10, 10, "the Teleop panel's twists")
        sample = device.latest()
        assert sample.velocity.values.tolist() == [0.2, 0.0, 0.0, 0.0, 0.0, 0.0]
        _wait(
            lambda: any(e.kind == "teleop_input" and e.fields.get("role") == "foxglove" for e in events),
            10,
            "foxglove driving",
        )
        viewer.screenshot(out / "teleop_pad.png")

        # mode vehicle_goal (a Publish panel), then a pose clicked in the 3D panel: place, then aim
        viewer.click("Vehicle to pose")
        _wait(
            lambda: any(e.kind == "teleop_mode" and e.fields.get("mode") == "vehicle_goal" for e in events),
            10,
            "the mode",
        )
        viewer.click_at(*_centre(viewer.rect(PUBLISH)))
        cx, cy = _centre(viewer.rect(CANVAS))
        viewer.click_at(cx, cy - 60)
        time.sleep(0.3)
        viewer.click_at(cx + 80, cy - 60)
        _wait(lambda: device.latest().pose is not None, 10, "the 3D panel's PoseStamped")
        pose = device.latest().pose
        assert pose.frame == "vehicle_level"
        _wait(
            lambda: any(e.kind == "teleop_goal" and e.fields.get("mode") == "vehicle_goal" for e in events),
            10,
            "the vehicle goal",
        )
        viewer.screenshot(out / "teleop_pose_goal.png")

        # mode tool_goal, "Publish point" from the long-press menu, one click
        viewer.click("Tool to point")
        _wait(
            lambda: any(e.kind == "teleop_mode" and e.fields.get("mode") == "tool_goal" for e in events), 10, "the mode"
        )
        viewer.click_at(*_centre(viewer.rect(PUBLISH)), hold_s=1.0)
        item = "[...document.querySelectorAll('li')].find(e => e.innerText.trim() === 'Publish point')"
        viewer.wait_for(lambda v: v.rect(item) is not None, 10, what="the publish type menu")
        viewer.click_at(*_centre(viewer.rect(item)))  # choosing the type starts the publishing
        time.sleep(0.5)
        viewer.click_at(cx, cy - 40)
        _wait(lambda: device.latest().point is not None, 10, "the 3D panel's PointStamped")
        assert device.latest().point.frame == "vehicle_level" and device.latest().point.values[2] == 0.0
        _wait(
            lambda: any(e.kind == "teleop_goal" and e.fields.get("mode") == "tool_goal" for e in events),
            10,
            "the tool goal",
        )
        viewer.screenshot(out / "teleop_point_goal.png")

        viewer.click("Hand back")
        _wait(
            lambda: any(e.kind == "control" and e.fields.get("who") == "autonomy" for e in events), 10, "the handback"
        )
    finally:
        release.set()
        if viewer is not None:
            viewer.close()
        run.join(180)
        server.close()
    r = result["r"]
    assert r.outcome == "succeeded", r.failure_cause
    logged = read_log(log).messages("/events")
    control = [e for e in logged if e["kind"] == "control"]
    assert "foxglove's handback button" in control[-1]["message"]
    assert any(e["kind"] == "operator_input" for e in logged) is False
