"""`maris log recover` on a log cut short, plots after an abort and overlaid,
`maris log tree` in py_trees' style."""

from __future__ import annotations

import contextlib
import io
from pathlib import Path

import pytest
from mcap.reader import make_reader

from mission.cli import main
from mission.logs.plots import plot_overlay, task_activation_series
from mission.logs.reader import read_log
from mission.logs.wellknown import log_entry
from mission.runtime.options import RunHooks, RunOptions, RunTarget

from .conftest import write_synthetic_log

ROOT = Path(__file__).resolve().parents[2]


def _run_cli(*argv: str) -> tuple[int, str]:
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = main(list(argv))
    return code, out.getvalue()


def test_recover_makes_a_cut_log_whole(tmp_path):
    path = tmp_path / "cut.mcap"
    w = write_synthetic_log(path, close=False)
    w.write_message("/log", 10**9, log_entry(10**9, "info", "test", "kept"))
    w.attach("model.urdf", "application/xml", b"<robot/>", 0.5)
    w.metadata("maris.run", {"mission": "m"})
    w.flush()
    size = path.stat().st_size
    with open(path, "ab") as f:  # what a kill -9 leaves: a partial record, then nothing
        f.write(b"\x05" + (10**12).to_bytes(8, "little") + b"partial")
    with open(path, "rb") as f, pytest.raises(Exception):  # noqa: B017 - mcap raises several types
        list(make_reader(f).iter_messages())  # the seeking reader refuses the cut file
    before = read_log(path)
    assert before.truncated
    code, out = _run_cli("log", "recover", str(path), "-o", str(tmp_path / "fixed.mcap"))
    assert code == 0 and "cut at:" in out
    with open(tmp_path / "fixed.mcap", "rb") as f:
        reader = make_reader(f)
        msgs = list(reader.iter_messages())
        assert [a.name for a in reader.iter_attachments()] == ["model.urdf"]
        assert [m.name for m in reader.iter_metadata()] == ["maris.run"]
    json_msgs = [m for s, c, m in msgs if c.message_encoding == "json"]
    assert len(json_msgs) == sum(len(v) for v in before.topics.values())
    assert any(c.topic == "/log" for _, c, _ in msgs)
    after = read_log(tmp_path / "fixed.mcap")
    assert not after.truncated and after.topics == before.topics
    assert size > 0


@pytest.mark.slow
def test_activations_plot_is_zero_for_tasks_left_at_an_abort(tmp_path):
    from mission.runtime.api import run_mission

    log_path = tmp_path / "abort.mcap"
    r = run_mission(
        RunTarget(ROOT / "missions" / "maris_pipe_recovery.yaml", seed=1),
        RunOptions(log_path=log_path),
        RunHooks(operator_script=[(30.0, "abort")]),
    )
    assert r.outcome == "aborted"
    log = read_log(log_path)
    t, series = task_activation_series(log)
    kcl = log.messages("/kcl")
    left = 0
    for i, m in enumerate(kcl):
        for name, task in (m.get("tasks") or {}).items():
            raw = max([a for a in task["activation"] if a is not None] or [0.0])
            assert series[name][i] == pytest.approx(raw * task["a_p"])
            if m["t"] > 31.0 and task["a_p"] == 0.0 and raw > 0.5:
                left += 1
                assert series[name][i] == 0.0
    assert left > 0, "no task of a left action stayed active in the raw telemetry: the case is not exercised"


@pytest.mark.slow
def test_overlay_of_two_logs(tmp_path):
    a, b = tmp_path / "filtered.mcap", tmp_path / "unfiltered.mcap"
    write_synthetic_log(a)
    write_synthetic_log(b, seconds=4.0)
    written, skipped = plot_overlay([read_log(a), read_log(b)], tmp_path / "ov")
    assert sorted(p.name for p in written) == [
        "overlay_joint_references.png",
        "overlay_tool_to_target.png",
        "overlay_vehicle_rates.png",
    ]
    assert skipped == []
    code, out = _run_cli("log", "plot", str(a), str(b), "--out", str(tmp_path / "cli"))
    assert code == 0 and out.count(".png") == 3
    for p in written:
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_log_tree_at_a_time_and_stepping(tmp_path):
    path = tmp_path / "tree.mcap"
    w = write_synthetic_log(path, close=False)
    nodes = [
        {"name": "Root", "kind": "sequence", "status": "RUNNING", "depth": 0},
        {"name": "Survey", "kind": "behaviour", "status": "SUCCESS", "depth": 1, "message": "found"},
        {"name": "Grasp", "kind": "behaviour", "status": "RUNNING", "depth": 1},
    ]
    w.write("/tree", 1.0, {"nodes": nodes[:2], "tip": "Survey", "root_status": "RUNNING"})
    w.write("/tree", 3.0, {"nodes": nodes, "tip": "Grasp", "root_status": "RUNNING"})
    w.close()
    code, out = _run_cli("log", "tree", str(path), "--at", "2")
    assert code == 0
    assert out.splitlines()[1:] == ["[-] Root [*]", "    --> Survey [✓] -- found"]
    code, out = _run_cli("log", "tree", str(path), "--step")
    assert code == 0 and out.count("[-] Root [*]") == 2 and "    --> Grasp [*]" in out
    code, _ = _run_cli("log", "tree", str(path), "--at", "0.5")
    assert code == 1
