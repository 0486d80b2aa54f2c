"""CSV export of a run log: one file per topic, nested fields flattened.

Column names join nested keys with ``.`` and list indices with ``[i]``, e.g.
``body_velocity[3]`` or ``tasks.tool_pose.activation[0]``. Rows keep log order;
a field missing from a message is an empty cell.
"""

from __future__ import annotations

import csv
from pathlib import Path

from mission.logs.reader import RunLog

#: Topics whose messages are text blobs, not time series (skipped by default).
TEXT_TOPICS = ("/run/source",)
#: The input record of `maris log replay`: nested per-call records, not a table
#: (skipped by default too; `--topic /replay/steps` still exports it).
RECORD_TOPICS = ("/replay/header", "/replay/steps")


def flatten(msg: object, prefix: str = "") -> dict[str, object]:
    """``{"a": {"b": [1, 2]}}`` -> ``{"a.b[0]": 1, "a.b[1]": 2}``."""
    out: dict[str, object] = {}
    if isinstance(msg, dict):
        for k, v in msg.items():
            out.update(flatten(v, f"{prefix}.{k}" if prefix else str(k)))
    elif isinstance(msg, list):
        if msg and all(isinstance(x, dict) for x in msg) and prefix.endswith("nodes"):
            out[prefix] = ";".join(f"{x.get('name')}={x.get('status')}" for x in msg)
        else:
            for i, v in enumerate(msg):
                out.update(flatten(v, f"{prefix}[{i}]"))
    else:
        out[prefix or "value"] = msg
    return out


def topic_filename(topic: str) -> str:
    return topic.strip("/").replace("/", "_") + ".csv"


def export_csv(log: RunLog, out_dir: str | Path, topics: list[str] | None = None) -> list[Path]:
    """Write ``<topic>.csv`` files into ``out_dir``; returns the paths written."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for topic, msgs in log.topics.items():
        if (
            (topics is not None and topic not in topics)
            or (topics is None and topic in TEXT_TOPICS + RECORD_TOPICS)
            or not msgs
        ):
            continue
        rows = [flatten(m) for m in msgs]
        columns = ["t"]
        seen = {"t"}
        for r in rows:
            for c in r:
                if c not in seen:
                    seen.add(c)
                    columns.append(c)
        path = out / topic_filename(topic)
        with open(path, "w", newline="", encoding="utf-8") as f:
            w = csv.DictWriter(f, fieldnames=columns, restval="")
            w.writeheader()
            for r in rows:
                w.writerow({k: ("" if v is None else v) for k, v in r.items()})
        written.append(path)
    return written
