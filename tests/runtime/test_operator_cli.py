"""Operator control through the real CLI in other processes: keys on a real
pseudo-terminal, SIGINT/SIGTERM on a real-time ``maris run``."""

from __future__ import annotations

import os
import pty
import re
import select
import signal
import subprocess
import sys
import time

import pytest

from mission.logs.reader import read_log

from .conftest import REFERENCE, ROOT, SCENARIO

pytestmark = [pytest.mark.slow, pytest.mark.realtime]  # realtime: a terminal and signals against a live run

ENV = dict(os.environ, PYTHONPATH=str(ROOT))


class PtyProcess:
    """A child process whose stdin/stdout/stderr are a pseudo-terminal."""

    def __init__(self, argv: list[str]):
        self.master, slave = pty.openpty()
        self.proc = subprocess.Popen(
            argv, stdin=slave, stdout=slave, stderr=slave, env=ENV, cwd=ROOT, start_new_session=True
        )
        os.close(slave)
        self.text = ""

    def expect(self, needle: str, timeout: float = 60.0, start: int = 0) -> int:
        """Read until ``needle`` appears after offset ``start``; returns its offset."""
        deadline = time.monotonic() + timeout
        while needle not in self.text[start:]:
            left = deadline - time.monotonic()
            assert left > 0, f"timed out waiting for {needle!r}; output so far:\n{self.text[-2000:]}"
            ready, _, _ = select.select([self.master], [], [], min(left, 0.5))
            if ready:
                try:
                    chunk = os.read(self.master, 4096)
                except OSError:
                    chunk = b""
                if not chunk:
                    assert needle in self.text[start:], f"process ended before {needle!r}:\n{self.text[-2000:]}"
                self.text += chunk.decode(errors="replace")
        return self.text.index(needle, start)

    def send(self, keys: bytes) -> None:
        os.write(self.master, keys)

    def finish(self, timeout: float = 60.0) -> int:
        try:
            while True:
                ready, _, _ = select.select([self.master], [], [], 0.2)
                if ready:
                    try:
                        chunk = os.read(self.master, 4096)
                    except OSError:
                        break
                    if not chunk:
                        break
                    self.text += chunk.decode(errors="replace")
                elif self.proc.poll() is not None:
                    break
            return self.proc.wait(timeout=timeout)
        finally:
            if self.proc.poll() is None:
                self.proc.kill()
            os.close(self.master)


def test_keys_pause_resume_abort_on_a_terminal(tmp_path):
    log_path = tmp_path / "keys.mcap"
    p = PtyProcess(
        [
            sys.executable,
            "-m",
            "mission.cli",
            "sim",
            str(REFERENCE),
            "--scenario",
            SCENARIO,
            "--seed",
            "1",
            "--realtime",
            "--log",
            str(log_path),
        ]
    )
    try:
        p.expect("keys: p pause")
        at = p.expect("running ", timeout=60)
        p.send(b"p")
        at = p.expect("operator: pause (key 'p')", start=at)
        p.expect("paused", start=at)
        time.sleep(0.5)
        p.send(b"r")
        at = p.expect("operator: resume (key 'r')", start=at)
        p.send(b"a")
        at = p.expect("abort_path", start=at)
        p.send(b"a")  # a second abort: safe stop now, skip the rest of the abort path
        code = p.finish()
    finally:
        if p.proc.poll() is None:
            p.proc.kill()
    assert code == 1, p.text[-2000:]
    assert "\x1b[" in p.text  # a terminal gets colour
    assert "outcome:   aborted" in re.sub(r"\x1b\[[0-9;]*m", "", p.text)
    log = read_log(log_path)
    assert not log.truncated
    states = [m["state"] for m in log.messages("/supervisor/state")]
    assert states == ["preflight", "running", "paused", "running", "aborting", "aborted"]
    sources = [m["fields"].get("source") for m in log.messages("/events") if m["kind"] == "operator"]
    assert sources == ["key 'p'", "key 'r'", "key 'a'", "key 'a'"]


def test_sigint_then_sigterm_on_field_run_close_the_log(tmp_path):
    """`maris run` (real time; HAL config = simulator): SIGINT aborts into the abort
    path, SIGTERM then safe-stops at once; the log is complete and closed."""
    log_path = tmp_path / "field.mcap"
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "mission.cli",
            "run",
            str(REFERENCE),
            "--hal",
            str(ROOT / "hal" / "configs" / "sim.yaml"),
            "--log",
            str(log_path),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env=ENV,
        cwd=ROOT,
    )
    try:
        first = proc.stdout.readline()
        assert first.startswith("t="), first
        time.sleep(1.0)
        proc.send_signal(signal.SIGINT)
        time.sleep(0.5)
        proc.send_signal(signal.SIGTERM)
        out, _ = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 1, out
    assert "operator: abort (SIGINT)" in out and "operator: stop_now (SIGTERM)" in out
    log = read_log(log_path)
    assert not log.truncated
    result = log.result
    assert result["outcome"] == "aborted" and "SIGINT" in result["failure_cause"]
    config = log.messages("/run/config")[0]
    assert config["realtime"] is True
    roles = {m["role"] for m in log.messages("/run/source")}
    assert {"mission", "hal_config"} <= roles
    assert not any(log.messages("/vehicle/command")[-1]["body_velocity"])
