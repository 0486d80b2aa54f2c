"""Writer -> independent reader (mcap package) -> our reader, summary, plots, CSV."""

from __future__ import annotations

import csv
import json

import pytest
from mcap.reader import make_reader

from mission.cli import main
from mission.logs.channels import CHANNELS
from mission.logs.export import export_csv, flatten
from mission.logs.plots import plot_all
from mission.logs.reader import LogError, read_log
from mission.logs.summary import format_summary, summarize
from mission.logs.wellknown import WELL_KNOWN
from mission.logs.writer import encode_json


def test_independent_reader_sees_schemas_and_json(synthetic_log):
    with open(synthetic_log, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        topics = {c.topic for c in summary.channels.values()}
        assert topics == set(CHANNELS) | set(WELL_KNOWN)
        for ch in summary.channels.values():
            if ch.topic in WELL_KNOWN:
                continue
            schema = summary.schemas[ch.schema_id]
            assert schema.encoding == "jsonschema" and ch.message_encoding == "json"
            assert json.loads(schema.data)["type"] == "object"
        kcl = [json.loads(m.data) for _, c, m in reader.iter_messages(topics=["/kcl"])]
    assert len(kcl) == 120
    assert kcl[50]["action"] == "grasp" and abs(kcl[50]["t"] - 2.5) < 1e-9


def test_non_finite_values_become_null_strict_json():
    data = encode_json({"v": [1.0, float("nan"), float("inf")], "x": float("-inf")})
    assert json.loads(data) == {"v": [1.0, None, None], "x": None}


def test_summary_reports_actions_grasp_limits_faults(synthetic_log):
    log = read_log(synthetic_log)
    assert not log.truncated
    s = summarize(log)
    assert s["outcome"] == "succeeded"
    assert [a for _, a in s["actions"]] == ["survey", "grasp", "transport"]
    assert abs(s["actions"][1][0] - 2.0) < 1e-9
    assert s["grasp"] == "holding"
    assert s["closest_to_limits"]["depth_m"]["margin"] == pytest.approx(7.0 - 0.1 * 5.95)
    assert s["faults"][0]["kind"] == "watchdog"
    text = format_summary(s)
    assert "survey @ 0.0 s  ->  grasp @ 2.0 s" in text and "depth_m" in text


@pytest.mark.slow
def test_plots_written_as_png(synthetic_log, tmp_path):
    written, skipped = plot_all(read_log(synthetic_log), tmp_path / "plots")
    names = sorted(p.name for p in written)
    assert names == ["joint_velocities.png", "task_activations.png", "tool_to_target.png", "vehicle_velocity.png"]
    assert skipped == []
    for p in written:
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and p.stat().st_size > 5000


def test_csv_export_flattens_vectors(synthetic_log, tmp_path):
    files = export_csv(read_log(synthetic_log), tmp_path / "csv")
    by_name = {p.name: p for p in files}
    with open(by_name["vehicle_command.csv"]) as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 120
    assert rows[0].keys() >= {"t", "body_velocity[0]", "body_velocity[5]"}
    assert float(rows[10]["body_velocity[5]"]) == 0.05
    assert flatten({"a": {"b": [1, 2]}}) == {"a.b[0]": 1, "a.b[1]": 2}


@pytest.mark.slow
def test_log_cli_summary_plot_export(synthetic_log, tmp_path, capsys):
    assert main(["log", "summary", str(synthetic_log)]) == 0
    assert "outcome:   succeeded" in capsys.readouterr().out
    assert main(["log", "summary", str(synthetic_log), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["grasp"] == "holding"
    assert main(["log", "plot", str(synthetic_log), "--out", str(tmp_path / "p")]) == 0
    assert len(list((tmp_path / "p").glob("*.png"))) == 4
    assert main(["log", "export", str(synthetic_log), "--csv", str(tmp_path / "c")]) == 0
    assert (tmp_path / "c" / "kcl.csv").exists()


def test_not_a_log_is_a_clear_error(tmp_path, capsys):
    bad = tmp_path / "bad.mcap"
    bad.write_text("hello")
    with pytest.raises(LogError):
        read_log(bad)
    assert main(["log", "summary", str(bad)]) == 2
    assert "not an MCAP run log" in capsys.readouterr().err
    assert main(["log", "summary", str(tmp_path / "missing.mcap")]) == 2


def test_log_cli_output_problems_are_clear_errors(synthetic_log, tmp_path, capsys):
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    assert main(["log", "plot", str(synthetic_log), "--out", str(blocker / "p")]) == 2
    assert main(["log", "export", str(synthetic_log), "--csv", str(blocker / "c")]) == 2
    assert (
        main(
            [
                "log",
                "export",
                str(synthetic_log),
                "--csv",
                str(tmp_path / "c"),
                "--topic",
                "/kcl",
                "--topic",
                "/no/such",
            ]
        )
        == 2
    )
    err = capsys.readouterr().err
    assert "cannot write plots to" in err and "cannot write CSV files to" in err
    assert "not in" in err and "/no/such" in err and "topics: " in err and "Traceback" not in err
    assert not (tmp_path / "c").exists()
