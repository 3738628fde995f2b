#!/usr/bin/env python3
"""Compares replayed ROBOT_STATE with the live ones at the same stamp.

usage: compare_states.py LIVE.jsonl REPLAYED.jsonl [--within-m 0.01] [--within-deg 0.5]
       [--share 0.99] [--max-dt-us 1000]
Both files are fieldline-bus-dump JSON lines of ROBOT_STATE. Every replayed state within the live
run (the first to the last live stamp: the replay starts with the recording, the live fusion a
little later) is paired with the live state of the nearest header.utime (within --max-dt-us);
prints the share of pairs within --within-m and --within-deg, the worst ones, and exits 1 if that
share is below --share or fewer than 95 % of the replayed states in the live run found a live
partner (the recorder may miss a message of a busy bus). Fusion publishes a second state with the
same stamp right after a camera frame corrected it: the k-th state of a stamp (in the order the
bus carried them) is paired with the k-th live state of its stamp, or the live stamp's last one.
"""
import argparse
import bisect
import json
import math
import sys


def states(path):
    """(utime, x, y, phi, status, k): k counts the earlier states of the same stamp."""
    out = []
    seen = {}
    with open(path) as f:
        for line in f:
            m = json.loads(line)["message"]
            t = m["header"]["utime"]
            k = seen.get(t, 0)
            seen[t] = k + 1
            out.append((t, m["x"], m["y"], m["phi"], m["status"], k))
    out.sort(key=lambda s: (s[0], s[5]))
    return out


def main():
    p = argparse.ArgumentParser()
    p.add_argument("live")
    p.add_argument("replayed")
    p.add_argument("--within-m", type=float, default=0.01)
    p.add_argument("--within-deg", type=float, default=0.5)
    p.add_argument("--share", type=float, default=0.99)
    p.add_argument("--max-dt-us", type=int, default=1000)
    p.add_argument("--label", default="")
    a = p.parse_args()
    live = states(a.live)
    replayed = states(a.replayed)
    times = [s[0] for s in live]
    pairs = []
    outside = [s for s in replayed if not live or s[0] < times[0] - a.max_dt_us
               or s[0] > times[-1] + a.max_dt_us]
    replayed = [s for s in replayed if s not in outside]
    for s in replayed:
        i = bisect.bisect_left(times, s[0])
        best = None
        for j in (i - 1, i):
            if 0 <= j < len(live) and (best is None or abs(times[j] - s[0]) < abs(times[best] - s[0])):
                best = j
        if best is None or abs(times[best] - s[0]) > a.max_dt_us:
            continue
        # The live state of that stamp with the same rank (its last when it has fewer).
        stamp = times[best]
        first = bisect.bisect_left(times, stamp)
        last = bisect.bisect_right(times, stamp) - 1
        l = live[min(first + s[5], last)]
        d = math.hypot(s[1] - l[1], s[2] - l[2])
        dphi = abs(math.degrees(math.atan2(math.sin(s[3] - l[3]), math.cos(s[3] - l[3]))))
        pairs.append((d, dphi, s[0], s[4], l[4]))
    if not replayed or not pairs:
        print(f"{a.label}: {len(replayed)} replayed, {len(live)} live, no pair")
        return 1
    good = sum(1 for d, dphi, *_ in pairs if d <= a.within_m and dphi <= a.within_deg)
    share = good / len(pairs)
    matched = len(pairs) / len(replayed)
    worst = sorted(pairs, reverse=True)[:3]
    print(f"{a.label}: {len(replayed)} replayed in the live run ({len(outside)} before or after "
          f"it), {len(live)} live, {len(pairs)} paired "
          f"({100 * matched:.1f} %), {good} within {a.within_m * 100:.1f} cm and "
          f"{a.within_deg} deg ({100 * share:.2f} %); worst "
          + ", ".join(f"{d * 100:.2f} cm {dphi:.2f} deg" for d, dphi, *_ in worst))
    return 0 if share >= a.share and matched >= 0.95 else 1


if __name__ == "__main__":
    sys.exit(main())
