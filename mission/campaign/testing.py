"""Stand-in run functions for testing executors (local pool, Dask cluster).

They must live in an importable module: worker processes (spawned by Dask's
nanny, or by the process pool) import them by name. Their behaviour is read
from the spec's ``overrides`` (free here: these functions are not missions):

* ``sleep_s``: seconds to sleep (in small steps, checking the run's deadline);
* ``marker_dir``: directory where each attempt leaves ``<index>.<pid>`` when it
  starts (tests find the process running a run there, and count attempts);
* ``die_on``: run indices whose process exits hard (``os._exit``), every attempt;
* ``hold_file`` / ``hold_on``: runs ``hold_on`` wait while that file exists.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

from mission.campaign.deadline import check_deadline
from mission.campaign.plan import RunSpec
from mission.campaign.records import RunRecord


def slow_run(spec: RunSpec) -> RunRecord:
    """A run that takes ``sleep_s`` of wall time and succeeds."""
    opts = spec.overrides
    marker_dir = opts.get("marker_dir")
    if marker_dir:
        Path(marker_dir, f"{spec.index}.{os.getpid()}").touch()
    if spec.index in opts.get("die_on", ()):
        os._exit(7)
    if spec.index in opts.get("hold_on", ()):
        while os.path.exists(opts["hold_file"]):
            check_deadline()
            time.sleep(0.02)
    end = time.monotonic() + float(opts.get("sleep_s", 0.0))
    while time.monotonic() < end:
        check_deadline()
        time.sleep(0.02)
    return RunRecord(spec.index, spec.seed, "success", duration_s=1.0)


def hanging_run(spec: RunSpec) -> RunRecord:
    """A run that never ends by itself and never checks its deadline (only a
    hard limit, SIGALRM in a worker's main thread, stops it)."""
    while True:
        time.sleep(0.05)
