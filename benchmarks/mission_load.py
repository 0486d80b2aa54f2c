"""Time to check large or hostile mission files (``load_mission``, what
``maris validate`` runs), in-process, after a warm-up load (imports and the
actions file cached).

Cases (each generated in a temporary folder):

* ``waypoints_1_9MB``: a valid mission with one survey action of as many
  waypoints as fit under the 2 MB file limit (about 31,000);
* ``oversize_5MB``: the same with 80,000 waypoints (5 MB): refused by size;
* ``alias_bomb``: nine levels of ten aliases each: refused at the first alias;
* ``subtree_chain_1000``: a chain of 1,000 subtrees: refused by the depth limit;
* ``deep_flow_10000``: a 10,000-deep flow list: refused by the nesting limit.

Prints the median wall time of ``--repeat`` loads per case (CPU time too: the
machine may be shared) and the peak memory of the process; the last line is
``mission_load <case>_s=<median> ... peak_mb=<MB>``.

    .venv/bin/python benchmarks/mission_load.py [--repeat 3]
"""

from __future__ import annotations

import argparse
import resource
import statistics
import tempfile
import time
from pathlib import Path

HEAD = """\
name: bench
safety:
  max_depth_m: 4.0
  min_altitude_m: 0.5
  max_duration_s: 600
  geofence: {north_m: [0, 25], east_m: [0, 12], down_m: [0, 4]}
abort: {action: {run: hold, timeout_s: 5}}
"""


def waypoints(n: int) -> str:
    rows = "".join(
        f"        - {{north_m: {i % 20 + 1}.123456, east_m: {i % 10 + 1}.654321, down_m: 2.0}}\n" for i in range(n)
    )
    return HEAD + "tree:\n  action:\n    run: survey\n    timeout_s: 500\n    targets:\n      waypoints:\n" + rows


def cases() -> dict[str, str]:
    from maris_common.yamltext import MAX_FILE_BYTES

    row = len("        - {north_m: 20.123456, east_m: 10.654321, down_m: 2.0}\n")  # the longest row
    fit = (MAX_FILE_BYTES - len(waypoints(0))) // row
    bomb = ['a0: &a0 ["x", "x", "x", "x", "x", "x", "x", "x", "x", "x"]']
    bomb += [f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 10)}]" for i in range(1, 9)]
    chain = HEAD + "tree: {subtree: s0}\nsubtrees:\n" + "".join(f"  s{i}: {{subtree: s{i + 1}}}\n" for i in range(1000))
    chain += "  s1000: {wait: {duration_s: 1}}\n"
    return {
        "waypoints_1_9MB": waypoints(fit),
        "oversize_5MB": waypoints(80_000),
        "alias_bomb": "\n".join(bomb) + "\n",
        "subtree_chain_1000": chain,
        "deep_flow_10000": HEAD + "tree: " + "[" * 10_000 + "]" * 10_000 + "\n",
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()

    from maris_common.yamlsrc import ConfigError
    from mission.loader import load_mission

    root = Path(__file__).resolve().parents[1]
    load_mission(root / "missions" / "survey_only.yaml")  # warm-up: imports, actions file
    figures = {}
    with tempfile.TemporaryDirectory() as d:
        for name, text in cases().items():
            path = Path(d) / f"{name}.yaml"
            path.write_text(text)
            walls, cpus, verdict = [], [], ""
            for _ in range(args.repeat):
                w0, c0 = time.perf_counter(), time.process_time()
                try:
                    m = load_mission(path)
                    verdict = (
                        f"valid ({len(m.tree.params['targets']['waypoints'] or [])} waypoints)"
                        if m.tree.kind == "action"
                        else "valid"
                    )
                except ConfigError as exc:
                    verdict = f"refused: {str(exc.issues[0])[len(str(path)) + 1 :][:90]}"
                walls.append(time.perf_counter() - w0)
                cpus.append(time.process_time() - c0)
            figures[name] = statistics.median(walls)
            print(
                f"{name:<20} {path.stat().st_size / 1e6:6.2f} MB  median {figures[name] * 1000:8.1f} ms wall, "
                f"{statistics.median(cpus) * 1000:8.1f} ms CPU  {verdict}"
            )
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"peak memory of the process: {peak_mb:.0f} MB")
    print("mission_load " + " ".join(f"{k}_s={v:.3f}" for k, v in figures.items()) + f" peak_mb={peak_mb:.0f}")


if __name__ == "__main__":
    main()
