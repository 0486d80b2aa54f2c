"""A writer killed with SIGKILL leaves a file that the independent ``mcap``
reader reads sequentially up to (at least) the last flush."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap

import pytest
from mcap.reader import NonSeekingReader

from mission.logs.reader import read_log

pytestmark = pytest.mark.realtime  # a writer killed at a wall-clock moment

CHILD = textwrap.dedent(
    """
    import sys, time
    from mission.logs.writer import RunLogWriter
    w = RunLogWriter(sys.argv[1], flush_interval_s=0.2)
    t, last = 0.0, time.monotonic()
    while True:
        t += 0.01
        w.write("/vehicle/command", t, {"body_velocity": [t, 0, 0, 0, 0, 0]})
        time.sleep(0.002)  # a modest message rate keeps the read-back quick
        if time.monotonic() - last >= 0.3:
            last = time.monotonic()
            print(f"{t:.2f}", flush=True)
    """
)


def read_until_cut(path):
    """Messages the mcap package yields before hitting the cut-off end."""
    out = []
    with open(path, "rb") as f:
        try:
            for _schema, channel, message in NonSeekingReader(f).iter_messages(log_time_order=False):
                out.append((channel.topic, json.loads(message.data)))
        except Exception:  # noqa: BLE001 - the file ends in a partial record
            pass
    return out


@pytest.mark.slow
def test_sigkill_leaves_readable_log(tmp_path):
    path = tmp_path / "killed.mcap"
    env = dict(os.environ, PYTHONPATH=os.getcwd())
    proc = subprocess.Popen([sys.executable, "-c", CHILD, str(path)], stdout=subprocess.PIPE, text=True, env=env)
    try:
        printed = [float(proc.stdout.readline()) for _ in range(6)]
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=10)
    assert proc.returncode == -signal.SIGKILL
    msgs = read_until_cut(path)
    assert msgs, "nothing readable"
    last_t = msgs[-1][1]["t"]
    assert last_t >= printed[4] - 1e-9
    times = [m["t"] for _, m in msgs]
    assert times == sorted(times) and abs(times[0] - 0.01) < 1e-9
    ours = read_log(path)
    assert ours.truncated
    assert len(ours.messages("/vehicle/command")) >= len(msgs)


def test_summary_of_a_cut_short_log_says_so(tmp_path, capsys):
    from mission.cli import main

    from .conftest import write_synthetic_log

    path = tmp_path / "open.mcap"
    w = write_synthetic_log(path, close=False)
    w.flush()  # as the periodic flush would; no footer, no /run/result yet
    assert main(["log", "summary", str(path)]) == 0
    out, err = capsys.readouterr()
    assert "cut short" in err and "outcome:   succeeded" in out  # the result message was flushed too
    w.close()
