"""The `maris` CLI as a new user meets it (issue 16): missions by name, JSON
outputs, --strict, colour, a closed pipe, the DOT text of `show`, scenarios,
`new`, `schema`, shell completion, `--filter-cutoff off`."""

from __future__ import annotations

import json
import math
import shutil
import subprocess
import sys
from pathlib import Path

import pydot
import pytest
import yaml

from mission.cli import main

ROOT = Path(__file__).resolve().parents[2]

SHORT = """\
name: short
safety:
  max_depth_m: 4.0
  min_altitude_m: 0.5
  max_duration_s: 30
  geofence: {north_m: [0, 25], east_m: [0, 12], down_m: [0, 4]}
tree:
  sequence:
    name: 'Odd "names": a\\b'
    children:
      - log: {message: "first: one"}
      - log: {message: "second: two"}
      - wait: {duration_s: 0.5}
abort:
  log: {message: "abort: ran"}
"""


@pytest.fixture
def short(tmp_path) -> Path:
    p = tmp_path / "short.yaml"
    p.write_text(SHORT)
    return p


# --------------------------------------------------------------------------- missions by name, JSON, strict


def test_shipped_missions_by_name(capsys):
    assert main(["validate", "survey_only", "maris_pipe_recovery"]) == 0
    out = capsys.readouterr().out
    assert "missions/survey_only.yaml: mission `survey_only` is valid" in out


def test_an_unknown_name_lists_the_shipped_missions(capsys):
    assert main(["validate", "survey_onl"]) == 1
    err = capsys.readouterr().err
    assert "no shipped mission of that name" in err and "survey_only" in err


def test_validate_json_and_strict(tmp_path, capsys):
    m = tmp_path / "w.yaml"
    m.write_text(SHORT + "subtrees:\n  spare: {wait: {duration_s: 1}}\n")
    assert main(["validate", str(m), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    (r,) = doc["missions"]
    assert doc["valid"] and r["valid"] and r["errors"] == [] and r["warnings"][0]["line"] == SHORT.count("\n") + 2
    assert r["warnings"][0]["severity"] == "warning" and "never used" in r["warnings"][0]["message"]
    assert main(["validate", str(m), "--strict"]) == 1
    assert "warning: subtrees.spare" in capsys.readouterr().err
    assert main(["validate", str(m)]) == 0
    assert ": warning: subtrees.spare" in capsys.readouterr().err


def test_sim_json_is_one_document(short, capsys):
    assert main(["sim", str(short), "--no-log", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["outcome"] == "succeeded" and doc["succeeded"] is True and "closest_to_limits" in doc


def test_sim_without_input_record_logs_all_else_and_replay_says_why(short, tmp_path, capsys):
    from mission.replay.rawlog import RawLog
    from mission.replay.schema import HEADER_TOPIC, STEP_TOPIC

    full, light = tmp_path / "full.mcap", tmp_path / "light.mcap"
    assert main(["sim", str(short), "--quiet", "--log", str(full)]) == 0
    assert main(["sim", str(short), "--quiet", "--log", str(light), "--no-input-record"]) == 0
    a, b = RawLog(full), RawLog(light)
    assert a.metadata["maris.run"]["input_record"] == "yes" and b.metadata["maris.run"]["input_record"] == "no"
    assert a.raw(HEADER_TOPIC) and a.raw(STEP_TOPIC) and not b.raw(HEADER_TOPIC) and not b.raw(STEP_TOPIC)
    assert set(a.topics) - set(b.topics) == {HEADER_TOPIC, STEP_TOPIC} and set(b.topics) <= set(a.topics)
    assert b.messages("/run/result")[-1]["outcome"] == a.messages("/run/result")[-1]["outcome"] == "succeeded"
    capsys.readouterr()
    assert main(["log", "replay", str(full), "--quiet"]) == 0
    assert main(["log", "replay", str(light), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "has no input record" in err and "the run left it out (`maris sim --no-input-record`)" in err


def test_filter_cutoff_off(short, capsys):
    from mission.commands._runner import controller_cutoff, filter_cutoff
    from mission.runtime.options import NO_FILTER_CUTOFF_RAD_S

    for word in ("off", "inf", "none"):
        assert controller_cutoff(filter_cutoff(word)) == NO_FILTER_CUTOFF_RAD_S
    assert filter_cutoff("30") == 30.0 and math.isinf(filter_cutoff("OFF"))
    assert main(["sim", str(short), "--no-log", "--quiet", "--filter-cutoff", "off"]) == 0
    assert main(["sim", str(short), "--no-log", "--quiet", "--filter-cutoff", "0"]) == 2
    assert "use `off` for no filter" in capsys.readouterr().err


# --------------------------------------------------------------------------- output hygiene


def test_no_colour_when_piped_or_with_no_color(monkeypatch, capsys):
    from mission.commands import _common

    assert main(["validate", "survey_only"]) == 0
    assert "\x1b[" not in capsys.readouterr().out  # capsys is not a terminal
    monkeypatch.setattr(_common, "COLOUR_MODE", "auto")

    class Tty:
        def isatty(self):
            return True

    assert _common.use_colour(Tty())
    monkeypatch.setenv("NO_COLOR", "1")
    assert not _common.use_colour(Tty())
    monkeypatch.setattr(_common, "COLOUR_MODE", "always")
    assert _common.paint("x", "red") == "\x1b[31mx\x1b[0m"


@pytest.mark.slow
def test_show_into_a_closed_pipe_ends_quietly(tmp_path):
    wide = tmp_path / "wide.yaml"  # its tree prints far more than a pipe buffers
    wide.write_text(
        SHORT.replace(
            "      - wait: {duration_s: 0.5}\n",
            "".join(f"      - log: {{message: 'line {i} of a long tree'}}\n" for i in range(3000)),
        )
    )
    proc = subprocess.Popen(
        [sys.executable, "-m", "mission.cli", "show", str(wide)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        cwd=ROOT,
    )
    proc.stdout.readline()
    proc.stdout.close()  # like `| head -1`
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=60) == 141
    assert "Traceback" not in err and "BrokenPipeError" not in err


# --------------------------------------------------------------------------- show: DOT text


@pytest.mark.slow
def test_dot_text_quotes_every_name_and_keeps_both_trees_apart(short, tmp_path):
    import py_trees

    from mission.compiler import compile_abort, compile_mission
    from mission.loader import load_mission

    dot_file = tmp_path / "t.dot"
    assert main(["show", str(short), "--dot", str(dot_file)]) == 0
    text = dot_file.read_text()
    (graph,) = pydot.graph_from_dot_data(text)
    mission = load_mission(short)
    expected = {"main tree": compile_mission(mission, None), "abort path": compile_abort(mission, None)}
    clusters = graph.get_subgraphs()
    assert [c.get_label().strip('"') for c in clusters] == list(expected)
    for cluster, root in zip(clusters, expected.values()):
        names = [b.name for b in root.iterate()]
        labels = [n.get_label()[1:-1].replace('\\"', '"').replace("\\\\", "\\") for n in cluster.get_nodes()]
        assert sorted(labels) == sorted(names)  # one DOT node per behaviour, names intact
    assert len(graph.get_edges()) == sum(len(list(r.iterate())) - 1 for r in expected.values())
    assert "main | abort" not in text and isinstance(expected["main tree"], py_trees.composites.Sequence)
    assert 'label="Odd \\"names\\": a\\\\b"' in text and 'label="Log: first: one"' in text


@pytest.mark.skipif(shutil.which("dot") is None, reason="graphviz `dot` not installed")
def test_graphviz_reads_the_dot_text_without_warnings(short, tmp_path):
    dot_file = tmp_path / "t.dot"
    assert main(["show", str(short), "--dot", str(dot_file)]) == 0
    proc = subprocess.run(["dot", "-Tsvg", str(dot_file)], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0 and proc.stderr == ""
    assert proc.stdout.count('class="node"') == 5  # 4 in the main tree, 1 in the abort path


def test_png_without_graphviz_draws_both_trees(short, tmp_path, monkeypatch):
    monkeypatch.setattr(shutil, "which", lambda name: None)
    png = tmp_path / "t.png"
    assert main(["show", str(short), "--png", str(png)]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


# --------------------------------------------------------------------------- scenarios, new, schema, completion


def test_scenarios_list_and_show_as_yaml(capsys):
    assert main(["scenarios", "list"]) == 0
    assert "pool_clear" in capsys.readouterr().out
    assert main(["scenarios", "show", "pool_clear"]) == 0
    doc = yaml.safe_load(capsys.readouterr().out)
    assert list(doc)[0] == "description" and doc["dvl"]["present"] is True and set(doc["pipe"]["x_m"]) == {"min", "max"}
    assert main(["scenarios", "show", "pool_clear", "--seed", "3"]) == 0
    drawn = yaml.safe_load(capsys.readouterr().out)
    assert isinstance(drawn["pipe"]["x_m"], float) and 11.5 <= drawn["pipe"]["x_m"] <= 13.5
    assert main(["scenarios", "show", "pool_clea"]) == 1
    assert "did you mean" in capsys.readouterr().err


def test_new_mission_from_templates(tmp_path, capsys):
    target = tmp_path / "my-dive.yaml"
    assert main(["new", str(target)]) == 0
    assert "name: my_dive" in target.read_text()
    assert main(["validate", str(target), "--strict"]) == 0
    assert main(["new", str(target)]) == 2  # never overwritten silently
    assert main(["new", str(tmp_path / "s"), "--from", "survey_only"]) == 0
    assert (tmp_path / "s.yaml").is_file()
    assert main(["new", str(tmp_path / "x"), "--from", "survey_onl"]) == 2
    assert "did you mean `survey_only`" in capsys.readouterr().err


def test_shipped_schema_is_the_generated_one(capsys):
    assert main(["schema"]) == 0
    assert capsys.readouterr().out == (ROOT / "docs" / "mission.schema.json").read_text()


def test_completion(capsys):
    from mission.commands._common import mission_completer, scenario_completer

    assert "survey_only" in mission_completer("surv")
    assert scenario_completer("pool_n") == ["pool_no_dvl"]
    for shell in ("bash", "zsh", "fish"):
        assert main(["completion", shell]) == 0
        assert "maris" in capsys.readouterr().out


# --------------------------------------------------------------------------- campaign criterion


def test_campaign_success_is_the_missions_own_criterion():
    from mission.campaign.records import RunRecord
    from mission.campaign.report import format_table
    from mission.commands.campaign import mission_grasps

    assert mission_grasps(str(ROOT / "missions" / "maris_pipe_recovery.yaml"))
    assert not mission_grasps(str(ROOT / "missions" / "survey_only.yaml"))
    records = [RunRecord(0, 1, "success"), RunRecord(1, 2, "not_detected")]
    table = format_table(records, criterion="mission")
    assert table.startswith("mission success rate: 1/2") and "grasp" not in table.split("\n", 1)[1]
    assert format_table(records).startswith("grasp success rate: 1/2")


@pytest.mark.slow
def test_campaign_json_of_a_mission_that_does_not_grasp(short, tmp_path, capsys):
    assert (
        main(
            [
                "campaign",
                str(short),
                "--scenario",
                "pool_fixed",
                "--runs",
                "1",
                "--workers",
                "1",
                "--out",
                str(tmp_path / "c"),
                "--json",
            ]
        )
        == 0
    )
    doc = json.loads(capsys.readouterr().out)
    assert doc["criterion"] == "mission" and doc["successes"] == 1 and doc["counts"]["success"] == 1
    assert doc["records"][0]["outcome"] == "success" and "traceback" not in doc["records"][0]
    assert (tmp_path / "c" / "summary.txt").read_text().startswith("campaign:")
