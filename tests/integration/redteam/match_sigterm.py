#!/usr/bin/env python3
"""Issue 34, red-team finding 3, the evaluation the issue asks for: fieldline-eval's match
scenario (six robots, 58.5 s) whose simulator is stopped with SIGTERM (a clean stop, as
`systemctl restart` sends) at 30 s; the launcher restarts it. Asserted on the evaluation's
samples.csv: no ROBOT_STATE with status TRACKING is more than --limit (0.5 m) from the truth, and
the restarted simulator said it resumed the world.

Run it inside its own network and mount namespaces (the simulator's pseudo-terminals and state
file go to /tmp/fieldline, shared by every run on the machine otherwise):
  unshare -n -m --propagation private python3 tests/integration/redteam/match_sigterm.py \
      --bin build/bin --out /tmp/match_sigterm
Prints one RESULT line (JSON). Not a ctest: a minute of six robots is too heavy for CI.
"""
import argparse
import csv
import json
import os
import pathlib
import signal
import subprocess
import sys
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent / "lib"))
from launcher_children import child_pid  # noqa: E402

TRACKING = 2


def launcher_of(eval_pid):
    """The fieldline-launch child of the evaluation."""
    return child_pid(eval_pid, "fieldline-launch")


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--bin", required=True)
    p.add_argument("--out", required=True)
    p.add_argument("--at", type=float, default=30.0, help="seconds after the team started")
    p.add_argument("--limit", type=float, default=0.5, help="m, largest error while TRACKING")
    p.add_argument("--scenario", default="match")
    a = p.parse_args()
    out = pathlib.Path(a.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    bin_ = pathlib.Path(a.bin).resolve()
    for cmd in ("ip link set lo up", "ip link set lo multicast on",
                "ip route add 224.0.0.0/4 dev lo"):
        subprocess.run(cmd.split(), check=True)
    # A private /tmp/fieldline (pseudo-terminals, the world's state file) in this mount namespace.
    os.makedirs("/tmp/fieldline", exist_ok=True)
    subprocess.run(["mount", "-t", "tmpfs", "tmpfs", "/tmp/fieldline"], check=True)
    load = os.getloadavg()
    log = open(out / "eval.log", "w")
    ev = subprocess.Popen([bin_ / "fieldline-eval", "--scenario", a.scenario, "--out", out / "eval"],
                          stdout=log, stderr=subprocess.STDOUT)
    stopped = None
    try:
        deadline = time.monotonic() + 60
        launcher = None
        while launcher is None and time.monotonic() < deadline:
            launcher = launcher_of(ev.pid)
            time.sleep(0.1)
        if launcher is None:
            sys.exit("FAIL: no fieldline-launch under fieldline-eval")
        sim = None
        while sim is None and time.monotonic() < deadline:
            sim = child_pid(launcher, "fieldline-world-sim")
            time.sleep(0.1)
        started = time.monotonic()
        while time.monotonic() < started + a.at and ev.poll() is None:
            time.sleep(0.1)
        sim = child_pid(launcher, "fieldline-world-sim")
        if sim is None:
            sys.exit("FAIL: no world_sim to stop")
        os.kill(sim, signal.SIGTERM)
        stopped = time.monotonic() - started
        rc = ev.wait(timeout=300)
    finally:
        if ev.poll() is None:
            ev.send_signal(signal.SIGINT)
            ev.wait(timeout=60)
    rows = list(csv.DictReader(open(out / "eval" / "samples.csv")))
    tracking = [r for r in rows if int(r["status"]) == TRACKING]
    worst = max(tracking, key=lambda r: float(r["pos_error_m"]), default=None)
    over = [r for r in tracking if float(r["pos_error_m"]) > a.limit]
    launch_log = (out / "eval" / "launch.log").read_text()
    summary = (out / "eval.log").read_text().strip().splitlines()
    result = {
        "stopped_at_s": round(stopped or -1, 1),
        "samples": len(rows), "tracking": len(tracking),
        "tracking_over_limit": len(over),
        "worst_tracking_m": round(float(worst["pos_error_m"]), 3) if worst else None,
        "worst_at": f"robot {worst['robot']} t {worst['t_s']} s" if worst else None,
        "resumed": "resumed the world" in launch_log,
        "eval_rc": rc, "load_before": [round(x, 1) for x in load],
        "load_after": [round(x, 1) for x in os.getloadavg()],
    }
    print("\n".join(line for line in summary if line.startswith(("pos_mean", "team_ball", "mean"))))
    print("RESULT " + json.dumps(result))
    if not result["resumed"]:
        sys.exit("FAIL: the restarted simulator did not resume the world")
    if over:
        sys.exit(f"FAIL: {len(over)} TRACKING samples more than {a.limit} m from the truth")
    print("PASS")


if __name__ == "__main__":
    main()
