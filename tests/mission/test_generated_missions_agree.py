"""Property: for generated missions that are deep, wide and long (nested
decorators and composites, many children, chains of subtrees), `maris
validate`, `maris show` and `maris sim` agree (all accept or all refuse with a
file:line error) and no traceback or internal error ever escapes.

Sizes straddle the limits of mission.structure (depth 40 through subtrees),
so both sides of each limit are exercised. Simulated missions are short
(max_duration_s 3 s, waits of a few hundredths of a second)."""

from __future__ import annotations

import contextlib
import io
import re
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from mission.cli import main

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
SIM_HAL = str(ROOT / "hal" / "configs" / "sim.yaml")

HEAD = """\
name: generated
safety:
  max_depth_m: 4.0
  min_altitude_m: 0.5
  max_duration_s: 3
  geofence: {north_m: [0, 25], east_m: [0, 12], down_m: [0, 4]}
blackboard:
  count: 0
abort:
  log: {message: "abort path"}
"""

LEAVES = [
    "{wait: {duration_s: 0.02}}",
    "{log: {message: 'step: ok'}}",
    "{set: {key: count, add: 1}}",
    "{condition: {blackboard: {key: count, at_least: 0}}}",
    "{action: {run: hold, timeout_s: 0.1}}",
]
WRAPPERS = [
    "{{sequence: {{children: [{0}]}}}}",
    "{{selector: {{memory: false, children: [{0}]}}}}",
    "{{parallel: {{policy: success_on_all, children: [{0}, {{log: {{message: side}}}}]}}}}",
    "{{retry: {{attempts: 2, child: {0}}}}}",
    "{{repeat: {{times: 1, child: {0}}}}}",
    "{{timeout: {{duration_s: 2, child: {0}}}}}",
    "{{one_shot: {{on: success, child: {0}}}}}",
    "{{guard: {{condition: {{blackboard: {{key: count, at_least: 0}}}}, child: {0}}}}}",
]


@st.composite
def missions(draw) -> str:
    leaf = st.sampled_from(LEAVES)
    # deep: a chain of decorators and composites around one leaf
    deep = draw(leaf)
    for wrapper in draw(st.lists(st.sampled_from(WRAPPERS), max_size=48)):
        deep = wrapper.format(deep)
    # wide: one sequence with many children
    wide = "{sequence: {children: [" + ", ".join(draw(st.lists(leaf, min_size=1, max_size=80))) + "]}}"
    # long: a chain of subtrees, each a leaf then the next subtree
    n = draw(st.integers(0, 40))
    subtrees = "".join(f"  s{i}: {{sequence: {{children: [{draw(leaf)}, {{subtree: s{i + 1}}}]}}}}\n" for i in range(n))
    subtrees += f"  s{n}: {draw(leaf)}\n"
    order = draw(st.permutations([deep, wide, "{subtree: s0}"]))
    return HEAD + f"tree: {{sequence: {{children: [{', '.join(order)}]}}}}\nsubtrees:\n{subtrees}"


def cli(*argv: str) -> tuple[int, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(list(argv))
    return code, out.getvalue() + err.getvalue()


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(missions())
def test_validate_show_and_sim_agree(text):
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "gen.yaml"
        path.write_text(text)
        v, v_out = cli("validate", str(path), "--hal", SIM_HAL)
        s, s_out = cli("show", str(path))
        r, r_out = cli("sim", str(path), "--no-log", "--quiet")
    event("accepted" if v == 0 else "refused")
    for out in (v_out, s_out, r_out):
        assert "Traceback" not in out and "internal error" not in out and "RecursionError" not in out, out[-3000:]
    if v == 0:
        assert s == 0 and r in (0, 1), (s_out[-2000:], r_out[-2000:])
        assert re.search(r"^outcome: +(succeeded|failed|aborted)", r_out, re.M)
    else:
        assert v == 1 and s == 1 and r == 2, (v_out, s_out[-2000:], r_out[-2000:])
        first = re.search(rf"{re.escape(str(path))}:(\d+):\d+: ", v_out)
        assert first and 1 <= int(first.group(1)) <= text.count("\n") + 1, v_out
