#!/usr/bin/env bash
# The whole simulated team, as scripts/demo runs it, in a private network namespace: every process
# the launch plan starts (those not built yet are skipped by the launcher, and so by this test)
# comes up and reports ok, every robot's channels flow at their rates, images arrive with their
# configured latency, nothing restarts, and the launcher stops everything cleanly (exit code 0).
#
# Bounded in time and robust to a loaded machine:
# - instead of a fixed sleep, fieldline-ready-probe waits until every process's SERVICE_STATUS says
#   ok, at most READY_TIMEOUT_S seconds;
# - a channel may lose at most 1 % of its messages (seq gaps, rounded up to whole messages) while
#   bus-stats listens: on a loaded machine a UDP socket buffer can overflow now and then.
# The launcher also has --duration as a backstop, so nothing outlives the test.
set -u
bin=$1
root=$2
READY_TIMEOUT_S=${READY_TIMEOUT_S:-60}
LISTEN_S=5
TEAM_S=3
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
export FIELDLINE_ROOT="$root"

# What the plan starts: "[r1 camera]" lines of the dry run that are not marked NOT BUILT.
"$bin/fieldline-launch" sim_team --dry-run > "$out/plan.txt" || { echo "FAIL: dry run"; exit 1; }
expect=$(sed -n 's/^# \[\(r[0-9]*\|sim\) \([a-z_0-9]*\)\] restart [a-z-]*$/\1\/\2/p' "$out/plan.txt")
if [ -z "$expect" ]; then echo "FAIL: no process in the launch plan"; cat "$out/plan.txt"; exit 1; fi
echo "--- expected to report ok: $(echo $expect | wc -w) processes"
skipped=$(sed -n 's/^# \[[a-z0-9]* \([a-z_0-9]*\)\].*NOT BUILT.*/\1/p' "$out/plan.txt" | sort -u)
[ -z "$skipped" ] || echo "--- not built, so neither started nor checked:" $skipped

# Private network and mount namespaces: its own buses and its own /tmp/fieldline (the
# simulator's serial lines and snapshot, fusion's pose files), not a running demo's.
ns="unshare -n -m --propagation private"
$ns true 2>/dev/null || ns="unshare -r -n -m --propagation private"
start=$(date +%s)
$ns bash -c "
  ip link set lo up; ip link set lo multicast on; ip route add 224.0.0.0/4 dev lo
  mkdir -p /tmp/fieldline && mount -t tmpfs tmpfs /tmp/fieldline
  '$bin/fieldline-launch' sim_team --duration $((READY_TIMEOUT_S + LISTEN_S + 40)) --no-table \
    --status-period 5 > '$out/launch.log' 2>&1 &
  launcher=\$!
  '$bin/fieldline-ready-probe' --robots 6 --sim --timeout $READY_TIMEOUT_S \
    $(for e in $expect; do printf -- '--expect %s ' "$e"; done) > '$out/probe.jsonl' 2> '$out/probe.log'
  echo \$? > '$out/probe.rc'
  '$bin/fieldline-bus-stats' --robots 6 --sim --duration $LISTEN_S --json > '$out/stats.jsonl' &
  stats=\$!
  # The demo check: every robot's TEAM_STATE, with all six present; robot 1's drawn to a PNG.
  # Recorded during the last TEAM_S seconds of bus-stats' listening (it followed it before: the
  # same healthy team, 3 s less of the test).
  sleep $((LISTEN_S - TEAM_S))
  if [ -x '$bin/fieldline-teamcomm' ]; then
    dumps=
    for r in 1 2 3 4 5 6; do
      '$bin/fieldline-bus-dump' --robot \$r --channel TEAM_STATE --duration $TEAM_S \
        > '$out/team_r'\$r.jsonl 2> /dev/null &
      dumps=\"\$dumps \$!\"
    done
    '$bin/fieldline-bus-dump' --sim --channel SIM_WORLD --duration $TEAM_S > '$out/sim_world.jsonl' \
      2> /dev/null &
    dumps=\"\$dumps \$!\"
    wait \$dumps
    if [ -x '$bin/fieldline-team-png' ]; then
      '$bin/fieldline-team-png' --robot 1 --out '$out/team_picture.png' --timeout 10 \
        > /dev/null 2> '$out/team_png.log'
    fi
  fi
  wait \$stats
  kill -TERM \$launcher
  wait \$launcher
  echo \$? > '$out/launch.rc'
"
echo "--- run took $(($(date +%s) - start)) s"
echo "--- launcher (last lines)"; tail -n 4 "$out/launch.log" | cut -c1-400
echo "--- probe"; cat "$out/probe.log"
echo "--- bus statistics"; cat "$out/stats.jsonl"
python3 - "$out" <<'PY'
import json, math, os, pathlib, re, sys
out = pathlib.Path(sys.argv[1])
failures = []
def lines(name):
    return [json.loads(l) for l in (out / name).read_text().splitlines() if l.strip()]
rc = int((out / "launch.rc").read_text().strip() or "-1")
if rc != 0:
    failures.append(f"launcher exit code {rc}")
if (out / "probe.rc").read_text().strip() != "0":
    failures.append("not every process reported ok in time (see the probe's lines)")
log = (out / "launch.log").read_text()
if "restarts=" in log:
    failures.append("a process was restarted")
stats = {(r["bus"], r["channel"]): r for r in lines("stats.jsonl")}
processes = lines("probe.jsonl")

# Every channel an ok process publishes (from its own SERVICE_STATUS), on its bus. Nominal rates;
# a loaded machine may lag, so the check is half of nominal. Channels without a nominal rate here
# (a process added later) must flow. The latency of camera-derived messages is at least the
# configured 60 ms by construction (exposure stamping).
nominal = {"SIM_WORLD": 100, "CAMERA_IMAGE": 30, "VISION_BALL": 30, "VISION_OBSTACLES": 30,
           "VISION_LINES": 30, "ODOMETRY": 50, "MOTION_COMMAND": 50, "FIELD_FEATURES": 30,
           "ROBOT_STATE": 50, "BALL_STATE": 30, "TEAM_STATE": 10}
MAX_LOST_SHARE = 0.01
expected = {(p["bus"], c) for p in processes for c in p["outputs"]}
# The plan's main channel of each built process, so a process that never publishes is caught.
plan = (out / "plan.txt").read_text()
main_channel = {}
name = None
launch_file = pathlib.Path(os.environ["FIELDLINE_ROOT"], "config/launch/sim_team.yaml")
for line in launch_file.read_text().splitlines():
    m = re.match(r"\s*- name:\s*(\w+)", line)
    if m:
        name = m[1]
    m = re.match(r"\s*main_channel:\s*(\w+)", line)
    if m and name:
        main_channel[name] = m[1]
for m in re.finditer(r"^# \[(r\d+|sim) (\w+)\] restart [a-z-]+$", plan, re.M):
    if m[2] in main_channel:
        expected.add((m[1], main_channel[m[2]]))
if not expected:
    failures.append("no channel to check")
def median_hz(msgs):
    """The rate from the median interval between the messages' stamps (0 without two)."""
    stamps = sorted(m["header"]["utime"] for m in msgs if "header" in m)
    gaps = sorted(b - a for a, b in zip(stamps, stamps[1:]))
    return 1e6 / gaps[len(gaps) // 2] if gaps and gaps[len(gaps) // 2] > 0 else 0.0
sim_dump = out / "sim_world.jsonl"
sim_msgs = [json.loads(l).get("message", {}) for l in sim_dump.read_text().splitlines()
            if l.strip()] if sim_dump.exists() else []
sim_world_hz = median_hz(sim_msgs) if len(sim_msgs) >= 20 else None
if sim_world_hz is not None:
    print(f"sim SIM_WORLD: {len(sim_msgs)} messages in 3 s at {sim_world_hz:.1f} Hz (median interval)")
for bus, channel in sorted(expected):
    r = stats.get((bus, channel))
    if r is None:
        failures.append(f"{bus} {channel}: no messages")
        continue
    hz = nominal.get(channel)
    if (bus, channel) == ("sim", "SIM_WORLD") and sim_world_hz is not None:
        # The simulator steps on a 100 Hz timer and publishes once per wake-up: a wake-up 10 ms
        # late merges two steps, which on a loaded machine took its rate to 44-66 Hz. Its stamps'
        # median interval stays 10 ms until half the wake-ups are late; a quarter of the rate
        # still catches a simulator that stops.
        if sim_world_hz < 0.9 * hz or r["rate_hz"] < hz / 4:
            failures.append(f"{bus} {channel}: {r['rate_hz']} Hz, {sim_world_hz:.1f} Hz by its "
                            f"stamps' median interval, expected {hz}")
    elif hz is not None and r["rate_hz"] < hz / 2:
        failures.append(f"{bus} {channel}: {r['rate_hz']} Hz, expected about {hz}")
    if hz is None and r["count"] < 2:
        failures.append(f"{bus} {channel}: {r['count']} messages")
    allowed = math.ceil(MAX_LOST_SHARE * (r["count"] + r["gaps"]))
    if r["gaps"] > allowed:
        failures.append(f"{bus} {channel}: {r['gaps']} of {r['count'] + r['gaps']} messages lost "
                        f"(at most {allowed}: {MAX_LOST_SHARE:.0%})")
    if channel.startswith(("CAMERA", "VISION")) and not 59.5 <= r["latency_p50_ms"] < 200:
        failures.append(f"{bus} {channel}: latency {r['latency_p50_ms']} ms")
# The demo check (issue 11): TEAM_STATE at 10 Hz on every robot's bus, with all six robots present
# (every robot's processes on its own clock, sim_team.yaml's `robots:`). The rate from the dumped
# pictures' own stamps (their median interval), not from their arrival: teamcomm skips the ticks
# it missed, so one 0.5 s pause of a loaded machine took the arrival rate of 5 s to 9.0 Hz; a
# wrong rate or pictures published per packet move the median. All six present in nearly every
# picture and in one of the last five: a teammate is absent only after 0.5 s without a packet, and
# a sender paused that long must not fail the test, a team that loses a robot for good does.
team_expected = any(c == "TEAM_STATE" for _, c in expected)
for r in range(1, 7) if team_expected else []:
    dump = out / f"team_r{r}.jsonl"
    msgs = [json.loads(l) for l in dump.read_text().splitlines() if l.strip()] if dump.exists() else []
    msgs = [m.get("message", m) for m in msgs]
    full = [sum(1 for p in m.get("present", []) if p) == 6 for m in msgs]
    hz = median_hz(msgs)
    print(f"r{r} TEAM_STATE: {len(msgs)} messages in 3 s at {hz:.2f} Hz (median interval), "
          f"{sum(full)} with all six present")
    if len(msgs) < 20:
        failures.append(f"r{r} TEAM_STATE: {len(msgs)} messages dumped")
        continue
    if not 9.0 <= hz <= 11.0:
        failures.append(f"r{r} TEAM_STATE: {hz:.2f} Hz by its stamps, expected 10")
    if sum(full) < 0.95 * len(msgs) - 1 or not any(full[-5:]):
        failures.append(f"r{r} TEAM_STATE: all six present in only {sum(full)} of {len(msgs)}")
if team_expected and os.environ.get("TEAM_PNG_OUT"):
    import shutil
    png = out / "team_picture.png"
    if png.exists():
        shutil.copy(png, os.environ["TEAM_PNG_OUT"])
    else:
        failures.append("no team picture PNG: " + (out / "team_png.log").read_text()[-300:])
lost = sum(stats[k]["gaps"] for k in expected if k in stats)
received = sum(stats[k]["count"] for k in expected if k in stats)
print(f"checked {len(expected)} channels of {len(processes)} processes: {received} messages, "
      f"{lost} lost to seq gaps")
for f in failures:
    print("FAIL:", f)
print("PASS" if not failures else f"{len(failures)} failures")
sys.exit(1 if failures else 0)
PY
