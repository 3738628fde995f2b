#!/usr/bin/env python3
"""Checks the team test network's records (see teamcomm_net_test.sh for the timeline)."""
import json
import pathlib
import re
import sys

out = pathlib.Path(sys.argv[1])
reference = int(sys.argv[2])
offsets = [int(v) for v in sys.argv[3].split()]
drifts = [float(v) for v in sys.argv[4].split()]
relay_log = (out / "relay.log").read_text()
start = int(re.search(r"start_us=(\d+)", relay_log).group(1))
attack = json.loads((out / "attack.json").read_text().strip().splitlines()[-1])
failures = []


def truth(i, j, t):
    """Robot j's clock minus robot i's (1-based) at system time t, us."""
    return (offsets[j] - offsets[i]) + (drifts[j] - drifts[i]) * 1e-6 * (t - reference)


def picture_time(r, utime):
    """System time of robot r's clock reading utime (the inverse of its offset and drift)."""
    d = drifts[r] * 1e-6
    return (utime - offsets[r] + d * reference) / (1 + d)


def p95(values):
    values = sorted(values)
    return values[min(len(values) - 1, int(0.95 * len(values)))] if values else float("nan")


def at(s):
    return start + int(s * 1e6)


states, statuses = {}, {}
for r in range(1, 7):
    lines = [json.loads(l) for l in (out / f"probe{r}.jsonl").read_text().splitlines() if l]
    states[r] = [l for l in lines if "utime" in l]
    statuses[r] = [l for l in lines if "status_t" in l]
    if len(states[r]) < 200:
        failures.append(f"robot {r}: only {len(states[r])} TEAM_STATE messages")

# 1. Offsets after 10 s of a clean link with asymmetric jitter: within 1 ms (p95), or within half
# the smallest round trip where that is more. One round trip bounds the offset to within half its
# length whatever the delays' asymmetry; the link's base delays make that 1-1.25 ms on a quiet
# machine (errors 0.2-0.3 ms there), but a loaded machine stretches every round trip (smallest
# ones 2.5-6.5 ms with one `yes` beside, errors 0.7-2 ms at 10-14 s, 0.5 ms from 14 s on: the fit
# still holds start-up's slow round trips). An estimator that averages instead of taking the
# smallest delays is off by 1.75 ms on robots 1 and 4 (their mean delays differ by 3.5 ms) in
# 13 % of the samples, and fails either way. The allowance trusts the link's own minimum round
# trip only up to 3.5 ms (so a round trip reported too long cannot loosen it further), and a
# round trip shorter than the relay's base delays (4 hops of 0.5 ms) is itself a fault.
errors, excess, round_trips = [], [], []
for r, recs in states.items():
    for s in recs:
        if at(10) <= s["t"] <= at(14):
            for j in range(1, 7):
                if j != r:
                    error = abs(s["offset"][j - 1] - truth(r, j, s["t"]))
                    errors.append(error)
                    excess.append(error / max(1000, min(s["rtt"][j - 1] / 2, 3500)))
                    if s["rtt"][j - 1] > 0:  # 0: no estimate yet (judged by the error alone)
                        round_trips.append(s["rtt"][j - 1])
offset_p95 = p95(errors)
print(f"offset error after 10 s: p95 {offset_p95 / 1e3:.3f} ms, "
      f"max {max(errors, default=float('nan')) / 1e3:.3f} ms "
      f"over {len(errors)} samples; p95 {p95(excess):.2f} of max(1 ms, half the round trip)")
if not errors or p95(excess) > 1:
    failures.append(f"offset error p95 {offset_p95} us: more than 1 ms and half the round trip "
                    f"in {sum(1 for e in excess if e > 1)} of {len(excess)} samples")
if round_trips and min(round_trips) < 1900:
    failures.append(f"a round trip of {min(round_trips)} us, shorter than the relay's 2 ms of base delays")

# 2. At 30 % loss: TEAM_STATE at 10 Hz, teammates' ages below 250 ms (p95), and teammates present
# in nearly every picture. Not in every one: the relay drops each forwarded copy on its own, and a
# teammate heard at 20 Hz is absent once ten copies in a row are lost (or arrive overtaken and are
# refused); at 30-35 % that is a few chances in a hundred per run over 30 teammate pairs (about
# 0.02-0.1 such stretches expected). A sender (or the relay) paused 0.5 s on a loaded machine
# leaves every receiver without it at once: a stretch shared by another receiver is the machine's.
# Unshared stretches are the link's or the receiver's: at most two, and at most 5 % of all reports.
# (This comment said a present timeout of half the default, five send periods, gives about 14
# stretches in a run; measured 2026-12-07 with `team.picture.present_timeout_s: 0.25` in
# net_team.yaml: one, in the 6.5 s window as in the 4.5 s one, and the test passed. See
# docs/log/2026-12-07-first-run.md, "Session 9 (teamtests)", for a timeout this check does catch.)
# The window: 15-19.5 s of the 14-20 s loss phase (8 s of loss and a 6.5 s window before issue 33).
# What it judges needs no more: the rate is the median of about 45 stamp intervals a robot, the
# age p95 is over about 1,300 teammate ages, the 5 % of absent reports is of 225 a robot.
def absent_stretches(window, r, j):
    """Consecutive pictures of robot r without teammate j, as (first, last) arrival times."""
    stretches, first, last = [], None, None
    for s in window:
        if not s["present"][j - 1]:
            first = s["t"] if first is None else first
            last = s["t"]
        elif first is not None:
            stretches.append((first, last))
            first = None
    if first is not None:
        stretches.append((first, last))
    return stretches


def also_absent_elsewhere(r, j, first, last):
    """Whether another receiver missed teammate j within 0.3 s of that stretch."""
    return any(not s["present"][j - 1] and first - 300_000 <= s["t"] <= last + 300_000
               for k, recs in states.items() if k not in (r, j) for s in recs)


ages = []
unshared = []
for r, recs in states.items():
    window = [s for s in recs if at(15) <= s["t"] <= at(19.5)]
    # The rate from the pictures' own stamps (their median interval), not from their arrival: a
    # probe or teamcomm descheduled for 0.35 s moved the arrival rate out of 9.5-10.5 Hz (a late
    # burst, or ticks skipped). Publishing on each packet instead of the 10 Hz timer, or a timer
    # at another rate, moves the median; a teamcomm that stops under loss leaves too few.
    stamps = sorted(s["utime"] for s in window)
    gaps = sorted(b - a for a, b in zip(stamps, stamps[1:]))
    rate = 1e6 / gaps[len(gaps) // 2] if gaps and gaps[len(gaps) // 2] > 0 else 0
    if not 9.5 <= rate <= 10.5 or len(window) < 0.5 * 4.5 * 10:
        failures.append(f"robot {r}: TEAM_STATE at {rate:.2f} Hz under loss "
                        f"({len(window)} pictures in 4.5 s)")
    absent = [(s, j) for s in window for j in range(1, 7) if j != r and not s["present"][j - 1]]
    for j in range(1, 7):
        for first, last in absent_stretches(window, r, j) if j != r else []:
            shared = also_absent_elsewhere(r, j, first, last)
            print(f"robot {r}: teammate {j} absent under loss at {(first - start) / 1e6:.1f}-"
                  f"{(last - start) / 1e6:.1f} s ({'also' if shared else 'not'} at another robot)")
            if not shared:
                unshared.append((r, j, first))
    if len(absent) > 0.05 * 5 * len(window):
        failures.append(f"robot {r}: teammates absent in {len(absent)} of {5 * len(window)} "
                        "teammate reports under loss")
    ages += [s["age"][j - 1] for s in window for j in range(1, 7) if j != r and s["present"][j - 1]]
if len(unshared) > 2:
    failures.append(f"{len(unshared)} stretches of a teammate absent at one robot alone under loss "
                    "(at most 2 by chance)")
# The ages' bound: 250 ms, or the clean link's p95 of this run (10-14 s) plus 150 ms where a
# loaded machine made that slower. Loss adds a few lost copies of 50 ms at p95 (three in a row at
# 30 %: 2.7 %), while everything else in an age is the machine's: the probe's and the sender's
# lateness. One `yes` beside: clean 85 ms, loss 149 ms; two: clean 128 ms, loss 258 ms.
# A teamcomm that keeps old poses or refuses the packets after a gap reaches the 500 ms timeout.
# Capped at 350 ms, and the clean link's own p95 at most 250 ms: ages too old in both phases
# must not raise their own bound.
clean_ages = [s["age"][j - 1] for r, recs in states.items() for s in recs
              if at(10) <= s["t"] <= at(14) for j in range(1, 7) if j != r and s["present"][j - 1]]
age_bound = min(max(250_000, p95(clean_ages) + 150_000), 350_000) if clean_ages else 250_000
print(f"teammate age at 30 % loss: p95 {p95(ages) / 1e3:.1f} ms, "
      f"max {max(ages, default=float('nan')) / 1e3:.1f} ms "
      f"(clean link: p95 {p95(clean_ages) / 1e3:.1f} ms; bound {age_bound / 1e3:.0f} ms)")
if not ages or p95(ages) > age_bound:
    failures.append(f"age p95 {p95(ages)} us > {age_bound} us under loss")
if not clean_ages or p95(clean_ages) > 250_000:
    failures.append(f"age p95 {p95(clean_ages)} us > 250 ms on the clean link")

# 3. The partition {1,2,3} | {4,5,6} from 20 s is reported, and healed within 1 s of 23 s. Judged
# at each picture's own time (its stamp on the robot's clock, taken back to system time), not at
# its arrival at the probe: on a loaded machine the probe read pictures up to a second late, and
# pictures from before the partition arrived inside it.
for r, recs in states.items():
    side = {1, 2, 3} if r <= 3 else {4, 5, 6}
    during = [s for s in recs if at(21) <= picture_time(r, s["utime"]) <= at(22.9)]
    # Nothing crosses the partition: a robot of the other side present is always wrong. A
    # teammate of its own side is absent only when nothing of it came for 0.5 s (a sender or the
    # relay descheduled that long on a loaded machine): at most 5 % of those reports, as at loss.
    across = [s for s in during if any(s["present"][j - 1] for j in range(1, 7) if j not in side)]
    missing = sum(1 for s in during for j in side if j != r and not s["present"][j - 1])
    if not during or across or missing > 0.05 * 2 * len(during):
        failures.append(f"robot {r}: partition not reported ({len(across)} of {len(during)} "
                        f"with the other side, {missing} own-side teammates absent)")
    healed = next((picture_time(r, s["utime"]) for s in recs
                   if picture_time(r, s["utime"]) >= at(23) and sum(s["present"]) == 6), None)
    if healed is None or healed - at(23) > 1_000_000:
        failures.append(f"robot {r}: not healed within 1 s ({healed and (healed - at(23)) / 1e6} s)")
    else:
        print(f"robot {r}: partition healed after {(healed - at(23)) / 1e3:.0f} ms")

# 4. The attack: every forged packet refused and counted by reason; the picture unchanged.
def rejected(status):
    return sum(v for k, v in status["errors"].items() if k.startswith("rejected_"))

total_refused = 0
# The counts before the attack: the statuses before its first forged packet, which cannot come
# before the attacker's launch + its 4 s of sniffing (at(24.5) alone assumed the relay, whose
# start is at(0), started no later than 0.5 s after the script's own clock).
launch_file = out / "attack_launch_us"
launch_text = launch_file.read_text().strip() if launch_file.exists() else ""
attack_from = (min(at(24.5), int(launch_text) + 4_000_000) if launch_text.isdigit()
               else at(24.5))
# Refusals as `late` of genuine teammates' packets: a loaded machine's relay can still reorder a
# few after the reordering phase. They are not the attacker's, so they may add to the count.
total_late = 0
for r in range(1, 7):
    before = [s for s in statuses[r] if s["status_t"] < attack_from]
    after = statuses[r][-1]
    if not before:
        failures.append(f"robot {r}: no SERVICE_STATUS before the attack")
        continue
    total_refused += rejected(after) - rejected(before[-1])
    total_late += after["errors"].get("rejected_late", 0) - before[-1]["errors"].get("rejected_late", 0)
    kinds = {k: v for k, v in after["errors"].items() if k.startswith("rejected_")}
    print(f"robot {r}: refused by reason {kinds}")
    # Up to 28 s: the attack ends at 27 s, and from 30 s the probes stop one by one.
    for s in states[r]:
        if at(24.5) <= s["t"] <= at(28):
            for j in range(1, 7):
                if j != r and s["present"][j - 1] and abs(s["x"][j - 1] - (j - 4)) > 0.05:
                    failures.append(f"robot {r}: teammate {j} moved to x={s['x'][j - 1]} during the attack")
                    break
    upto = [s for s in states[r] if s["t"] <= at(28)]
    if not upto:
        failures.append(f"robot {r}: no TEAM_STATE before 28 s")
        continue
    last = upto[-1]
    if sum(r_ for r_ in last["rejected"]) == 0:
        failures.append(f"robot {r}: TEAM_STATE.packets_rejected shows nothing")
    if not last["team_ball"][0] or abs(last["team_ball"][1] - 2.0) > 0.1:
        failures.append(f"robot {r}: team ball {last['team_ball']}, expected (2, -1)")
kernel_drops = sum(int((out / f"rcvbuf_errors{r}").read_text().strip() or 0) for r in range(1, 7))
print(f"attacker sent {attack['total']}, the robots refused {total_refused}, "
      f"the kernel dropped {kernel_drops} for full receive buffers")
extra = total_refused + kernel_drops - attack["total"]
if extra < 0 or extra > total_late:
    failures.append(f"attack: sent {attack['total']}, refused {total_refused} "
                    f"({total_late} of them late teammates' packets)")
elif extra > 0:
    print(f"({extra} of the refusals were teammates' packets reordered by the loaded relay: late)")

for f in failures[:30]:
    print("FAIL:", f)
print("PASS" if not failures else f"{len(failures)} failures")
sys.exit(1 if failures else 0)
