#!/usr/bin/env python3
"""Seconds each robot spent on its symmetric twin, from fieldline-eval's samples.csv.

A sample is on the twin as fieldline-eval counts wrong half: TRACKING, within 0.5 m of the
truth's mirror image (-x, -y) and more than 1 m from the truth. Prints, per file, the total per
robot and each episode (start time, duration) (docs/log/2026-12-03-fusion.md, "Twelfth round").

    bench/fusion/twin_time.py OUT/samples.csv [MORE.csv ...]
"""
import csv
import math
import sys


def episodes(path):
    """{robot: [(start_s, duration_s), ...]}"""
    out = {}
    start = {}
    last = {}
    with open(path, newline="") as f:
        for r in csv.DictReader(f):
            robot, t = r["robot"], float(r["t_s"])
            x, y, tx, ty = (float(r[k]) for k in ("x", "y", "true_x", "true_y"))
            twin = (r["status"] == "2" and math.hypot(x + tx, y + ty) < 0.5
                    and float(r["pos_error_m"]) > 1.0)
            if twin and robot not in start:
                start[robot] = last.get(robot, t)
            if not twin and robot in start:
                out.setdefault(robot, []).append((start[robot], t - start.pop(robot)))
            last[robot] = t
    for robot, s in start.items():
        out.setdefault(robot, []).append((s, last[robot] - s))
    return out


def main(paths):
    if not paths:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    for path in paths:
        eps = episodes(path)
        if not eps:
            print(f"{path}: no twin")
            continue
        for robot, e in sorted(eps.items()):
            listed = ", ".join(f"{s:.1f} s for {d:.2f} s" for s, d in e)
            print(f"{path}: robot {robot} {sum(d for _, d in e):.2f} s on the twin ({listed})")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
