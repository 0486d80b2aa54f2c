"""Reuses the simulator-backed test context of tests/behaviours/conftest.py
(test folders are not packages, so it is loaded by path)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

_spec = importlib.util.spec_from_file_location(
    "behaviours_test_ctx", Path(__file__).parents[1] / "behaviours" / "conftest.py"
)
_ctx = importlib.util.module_from_spec(_spec)
sys.modules[_spec.name] = _ctx
_spec.loader.exec_module(_ctx)

SimContext = _ctx.SimContext
RecordingController = _ctx.RecordingController
tick_until = _ctx.tick_until
scenario = _ctx.scenario
make_ctx = _ctx.make_ctx
tick = _ctx.tick
KclSimContext = _ctx.KclSimContext
kcl_parts = _ctx.kcl_parts
make_kcl_ctx = _ctx.make_kcl_ctx
