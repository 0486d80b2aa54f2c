"""Table, CSV (read back with the csv module) and PNG chart (read back with matplotlib)."""

import csv

import numpy as np
import pytest

from mission.campaign.records import RunRecord
from mission.campaign.report import format_table, plot_summaries, write_csv
from mission.campaign.stats import summarize


def _records():
    return [
        RunRecord(1, 11, "timeout", 120.0, "timeout", "none", {"osc_rms": 0.5}),
        RunRecord(0, 10, "success", 61.25, None, "holding", {"osc_rms": 0.01}),
        RunRecord(2, 12, "error", error="RuntimeError: boom\nsecond line", traceback="Traceback ..."),
        RunRecord(3, 13, "success", 70.0, None, "holding", {"osc_rms": float("nan")}),
    ]


def test_table_text():
    text = format_table(_records(), "demo")
    assert text.splitlines()[0] == "demo"
    assert "success rate: 2/4 = 50.0 % (95 % CI 15.0-85.0 %)" in text
    assert "timeout            1   25.0 %" in text
    assert "run 2 (seed 12) raised: RuntimeError: boom" in text


def test_csv_round_trip(tmp_path):
    path = write_csv(_records(), tmp_path / "sub" / "c.csv")
    with path.open() as f:
        rows = list(csv.DictReader(f))
    assert [r["index"] for r in rows] == ["0", "1", "2", "3"]
    assert rows[0]["outcome"] == "success" and float(rows[0]["duration_s"]) == 61.25
    assert rows[1]["failure_cause"] == "timeout" and float(rows[1]["m_osc_rms"]) == 0.5
    assert rows[2]["error"] == "RuntimeError: boom second line" and rows[2]["m_osc_rms"] == ""
    assert rows[3]["m_osc_rms"] == "nan"


@pytest.mark.slow
def test_chart_png(tmp_path):
    import matplotlib.image as mpimg

    groups = [("a", summarize(_records())), ("b", summarize(_records()[:2]))]
    path = plot_summaries(groups, tmp_path / "c.png", reference={"a": (0.25, 0.31)}, title="t")
    img = mpimg.imread(path)
    assert img.ndim == 3 and img.shape[0] > 200 and img.shape[1] > 500
    assert np.std(img[..., :3]) > 0.05  # something was drawn
