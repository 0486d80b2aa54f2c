"""Per-run wall-clock limit of a campaign run.

:func:`run_deadline` wraps one run (the executor's ``guarded_call``). The limit
is enforced two ways:

* cooperatively: :func:`check_deadline` raises :class:`RunTimeout` once the
  limit has passed; the real run function (:func:`mission.campaign.single.run_one`)
  calls it at every tree tick of the supervisor (its ``on_progress`` hook) and
  once more after the run, so a run that overstays stops at its next tick, its
  log is closed and it is recorded as an ``error`` (it works in any thread:
  local worker processes and Dask worker threads);
* hard, when the run executes in the main thread of its process (the local
  process pool): ``SIGALRM`` raises :class:`RunTimeout` wherever the run is,
  even outside the supervisor loop. Dask runs tasks in worker threads, where
  signals cannot be used: there only the cooperative check applies.
"""

from __future__ import annotations

import contextlib
import math
import signal
import threading
import time
from collections.abc import Iterator

_local = threading.local()


class RunTimeout(Exception):
    """A run exceeded its wall-clock limit."""


def _limit_text(seconds: float) -> str:
    return f"run exceeded its wall-clock limit of {seconds:g} s"


@contextlib.contextmanager
def run_deadline(seconds: float | None) -> Iterator[None]:
    """Limit the enclosed run to ``seconds`` of wall-clock time (None or <= 0:
    no limit). Nested limits are not supported (the inner one wins)."""
    if not seconds or not 0 < seconds < math.inf:
        yield
        return
    _local.deadline = time.monotonic() + seconds
    _local.seconds = seconds
    hard = threading.current_thread() is threading.main_thread() and hasattr(signal, "setitimer")
    previous = None
    if hard:

        def on_alarm(_signum, _frame):
            raise RunTimeout(_limit_text(seconds))

        previous = signal.signal(signal.SIGALRM, on_alarm)
        signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        if hard:
            signal.setitimer(signal.ITIMER_REAL, 0.0)
            signal.signal(signal.SIGALRM, previous)
        _local.deadline = None


def check_deadline() -> None:
    """Raise :class:`RunTimeout` if the current thread's run is past its limit."""
    deadline = getattr(_local, "deadline", None)
    if deadline is not None and time.monotonic() > deadline:
        raise RunTimeout(_limit_text(_local.seconds))
