"""The BlueROV2 acceptance run against ArduSub SITL, in an isolated network namespace:
nothing it starts can reach or be reached from another computer.

    unshare -rn .venv/bin/python tools/sitl_acceptance.py --ardupilot ../ardupilot --out runs/sitl

It brings the namespace's loopback up, starts SITL (the Heavy's ``vectored_6dof`` frame,
its ``sub-6dof.parm`` defaults plus ``tools/sitl_lab.parm``, at sea level: ArduSub's SITL
barometer reads the altitude above sea level as a negative depth), puts the vehicle into
the pool (``tools/sitl_preposition.py``), starts the Reach Alpha 5 peer on a
pseudo-terminal (a 5 mm object between the jaw's fingers: the pipe the simulated
detection shows) and the Ping peer following SITL's depth above a 3 m floor, then runs
``maris hal check`` and ``maris run missions/bluerov2_pipe_grasp.yaml`` with
``hal/configs/bluerov2_sitl.yaml`` and prints what they printed.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from hal.testing.peers import Peer, peer_report  # noqa: E402 - the repository's own peers, after its path

LINK = Path("/tmp/maris-sitl/alpha5")  # hal/configs/bluerov2_sitl.yaml's arm device


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--ardupilot", type=Path, required=True, help="the ArduPilot tree with build/sitl/bin/ardusub")
    ap.add_argument("--out", type=Path, default=ROOT / "runs" / "sitl")
    ap.add_argument("--start", default="2.75,4.0", help="north,east (m) to put the vehicle at before the run")
    ap.add_argument("maris_args", nargs="*", help="more options of `maris run` (after --)")
    args = ap.parse_args()
    subprocess.run(["ip", "link", "set", "lo", "up"], check=True)
    out = args.out.resolve()
    (out / "sitl").mkdir(parents=True, exist_ok=True)
    LINK.parent.mkdir(parents=True, exist_ok=True)
    py = sys.executable
    defaults = f"{args.ardupilot}/Tools/autotest/default_params/sub-6dof.parm,{ROOT}/tools/sitl_lab.parm"
    sitl_cmd = [str(args.ardupilot / "build/sitl/bin/ardusub"), "-S", "-w", "-I0", "--model", "vectored_6dof"]
    sitl_cmd += ["--speedup", "1", "--home", "-35.363261,149.165230,0,0", "--defaults", defaults]
    t0 = time.time()
    with open(out / "sitl.log", "w") as sitl_log:
        sitl = subprocess.Popen(sitl_cmd, cwd=out / "sitl", stdout=sitl_log, stderr=subprocess.STDOUT)
    peers: list[Peer] = []
    try:
        time.sleep(5)
        north, east = args.start.split(",")
        pre = [py, str(ROOT / "tools/sitl_preposition.py"), "tcp:127.0.0.1:5760", north, east]
        r = subprocess.run(pre, capture_output=True, text=True, timeout=400)
        print(f"== preposition (exit {r.returncode})\n{r.stdout}{r.stderr[-2000:]}", flush=True)
        reach = Peer("hal.testing.reach_peer", "--transport", "serial", "--arm", "alpha5", max_runtime=1800)
        peers.append(reach)
        if LINK.is_symlink() or LINK.exists():
            LINK.unlink()
        LINK.symlink_to(reach.ready)
        reach.send(cmd="object", width_mm=5.0)
        ping = [
            "--transport",
            "udp",
            "--port",
            "9090",
            "--follow-mavlink",
            "tcp:127.0.0.1:5763",
            "--floor-depth",
            "3.0",
        ]
        peers.append(Peer("hal.testing.ping_peer", *ping, max_runtime=1800))
        time.sleep(2)
        config = str(ROOT / "hal/configs/bluerov2_sitl.yaml")
        model = str(ROOT / "kcl/data/bluerov2_heavy_alpha5.urdf")
        for what, cmd in (
            ("maris hal check", ["hal", "check", config, "--model", model]),
            (
                "maris run",
                [
                    "run",
                    str(ROOT / "missions/bluerov2_pipe_grasp.yaml"),
                    "--hal",
                    config,
                    "--log",
                    str(out / "run.mcap"),
                ]
                + args.maris_args,
            ),
        ):
            t = time.time()
            r = subprocess.run([py, "-m", "mission.cli", *cmd], cwd=ROOT, capture_output=True, text=True, timeout=900)
            print(f"== {what} (exit {r.returncode}, {time.time() - t:.1f} s)\n{r.stdout}{r.stderr[-4000:]}", flush=True)
        print("reach peer:", peer_report(reach), flush=True)
    finally:
        for p in peers:
            p.stop()
        sitl.terminate()
        sitl.wait(10)
        print(f"== total {time.time() - t0:.1f} s", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
