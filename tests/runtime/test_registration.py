"""The packages built on the runtime and the logs plug in by registration: the
replay's input record and log channels; nothing imports the replay back."""

from __future__ import annotations

import subprocess
import sys

import pytest

from hal.testing.peers import ROOT
from mission.logs.channels import CHANNELS, register_channels
from mission.replay.schema import REPLAY_CHANNELS


def _python(code: str) -> list[str]:
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    return out.stdout.strip().splitlines()


@pytest.mark.slow
def test_a_log_with_inputs_needs_the_registered_recorder(tmp_path) -> None:  # noqa: ANN001
    """Without mission.replay.record imported, run_mission refuses a log with the input
    record (naming the fix) before it builds or writes anything."""
    log = tmp_path / "run.mcap"
    lines = _python(
        "import sys\n"
        "from mission.runtime.api import run_mission\n"
        "from mission.runtime.options import RunOptions, RunTarget\n"
        "try:\n"
        f"    run_mission(RunTarget('missions/survey_only.yaml'), RunOptions(log_path={str(log)!r}))\n"
        "except RuntimeError as exc:\n"
        "    print('refused:', exc)\n"
        "print('mission.replay' in sys.modules)\n"
    )
    assert lines[0].startswith("refused: ") and "import mission.replay.record" in lines[0]
    assert lines[1] == "False" and not log.exists()


def test_replay_channels_are_registered_with_the_logs() -> None:
    for topic, channel in REPLAY_CHANNELS.items():
        assert CHANNELS[topic] == channel
    register_channels(REPLAY_CHANNELS)  # again, the same: accepted
    topic = next(iter(REPLAY_CHANNELS))
    with pytest.raises(ValueError, match="registered twice"):
        register_channels({topic: ("maris.Other", {"type": "object", "properties": {}})})
