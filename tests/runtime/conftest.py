"""One reference dry run shared by the runtime tests (it is the slow part)."""

from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
REFERENCE = ROOT / "missions" / "maris_pipe_recovery.yaml"
SCENARIO = "pool_fixed"


@pytest.fixture(scope="session")
def reference_run(tmp_path_factory):
    """``maris sim`` of the reference mission (seed 1): (exit code, stdout, log path)."""
    import contextlib
    import io

    from mission.cli import main

    log = tmp_path_factory.mktemp("ref") / "ref.mcap"
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = main(["sim", str(REFERENCE), "--scenario", SCENARIO, "--seed", "1", "--log", str(log)])
    return code, out.getvalue(), log
