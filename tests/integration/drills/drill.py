#!/usr/bin/env python3
"""Fault drills on a small simulated team (issue 14 part 3), run inside a private network namespace.

One run of the launcher with robot 1's processes and the simulator (a launch file generated into
the run's folder, so the pseudo-terminals are private and the first restart comes after 50 ms),
two fieldline-bus-dump recorders (robot 1's bus and the simulator's) that stamp every arrival,
then the faults one after another, each followed by a wait for its recovery to be recorded
(the channel back at rate, the estimate watched for FAULT_REACH_S, fusion's status read; the
drill reads the recordings as they grow) rather than a fixed pause:

  kill    kill -9 of each process kind of robot 1 and of the simulator
  stop    SIGSTOP of the camera for 2 s, then SIGCONT; then of region tracking for 3 s (the frames
          left in its socket are older than fusion's window when it resumes: their lines must be
          refused, and this is the fault that makes sure such lines exist)
  serial  the motor controller's serial line cut (world_sim's SIGUSR1 outage) and restored
  all     the three above one after another in one run of the team (ctest's way, issue 33: one
          start-up and baseline instead of three; each fault is judged on its own window all the
          same). `drill.py DRILL --analyse-only --out DIR` then judges one drill's faults of it.

For each fault it measures, from the recordings: the time from the fault to the new process (the
launcher's restart), from there to the first message and to the channel back at full rate (the
first arrival from which the next second holds 90 % of the channel's nominal rate), and the
estimate against the simulator's truth at the same utime (the largest step of the error between
two consecutive ROBOT_STATE messages, and the largest error). Prints one JSON line per fault
(`RESULT {...}`) and a table, and fails on what must not happen: a process that does not come
back, a channel not back at rate within a generous bound, a stale frame fused (an estimate step
above 20 cm caused by the fault), fusion's estimate left wrong.
"""
import argparse
import bisect
import json
import math
import os
import pathlib
import signal
import subprocess
import sys
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent / "lib"))
from launcher_children import child_pid  # noqa: E402

# common/bus/channels.hpp nominalRateHz (the channel table).
NOMINAL_HZ = {"SIM_WORLD": 100, "CAMERA_IMAGE": 30, "VISION_LINES": 10, "FIELD_FEATURES": 10,
              "ODOMETRY": 50, "MOTION_COMMAND": 30, "ROBOT_STATE": 50, "TEAM_STATE": 10}
# Process kind -> (executable, main channel, bus). The order is the order of the kills.
KINDS = {
    "camera": ("fieldline-camera", "CAMERA_IMAGE", "r1"),
    "region_tracking": ("fieldline-region-tracking", "VISION_LINES", "r1"),
    "feature_recognition": ("fieldline-feature-recognition", "FIELD_FEATURES", "r1"),
    "fusion": ("fieldline-fusion", "ROBOT_STATE", "r1"),
    "motor_bridge": ("fieldline-motor-bridge", "ODOMETRY", "r1"),
    "pilot": ("fieldline-pilot", "MOTION_COMMAND", "r1"),
    "teamcomm": ("fieldline-teamcomm", "TEAM_STATE", "r1"),
    "world_sim": ("fieldline-world-sim", "SIM_WORLD", "sim"),
}
RATE_SHARE = 0.9          # "full rate": this share of the nominal rate within one second
# Asserted: back at full rate within this long after the restart. Generous: on the shared 2-core
# machine under a load of 12 a process can wait seconds for a core; the measured figures go to
# docs/drills.md, the test only catches a process that does not recover.
RATE_BOUND_S = 15.0
JUMP_LIMIT_M = 0.20       # asserted: no estimate step above this after a fault ...
# ... from the fault until this long after the restart: where a fault's stale or wrongly timed
# inputs act (fusion refuses inputs older than its 1 s window). Later steps are reported
# (max_jump_settle_m, with when and fusion's slip count) but belong to the estimator, not to
# the fault: a 0.28 m step 3-5 s after a feature recognition restart failed CI once, a frame
# matched to an aliased line taken as a slip, now bounded by fusion's slip_max_speed.
FAULT_REACH_S = 3.0
# After each fault the drill waits for what it measures, read from the recordings as they grow
# (Recording.window_end): the channel back at full rate and one second of it recorded, the
# FAULT_REACH_S window (from the first message, for fusion from its convergence) plus 0.5 s, and
# a SERVICE_STATUS of fusion (of the bridge after a serial cut) after that. The window ends there;
# it used to be a fixed 6 s. WAIT_S bounds the wait: past it the analysis reports what is missing
# (the rate bound and its one second, and some slack: at a load of 20 a camera restart took 10 s
# to its first frame, and the window of that fault 14.2 s).
WAIT_S = RATE_BOUND_S + 1.5
BASELINE_S = 3.0          # ROBOT_STATE with truth recorded before the first fault (error_before)
OUTAGE_S = 1.0            # serial line away for this long
STOP_S = 2.0              # camera stopped for this long
# Region tracking stopped for this long: its socket keeps the first ~1 s of frames (its receive
# buffer), so at the resume the newest of them is about 2 s old, past fusion's 1 s window.
STOP_TRACKING_S = 3.0


def now_us():
    return time.time_ns() // 1000


def launch_file(folder, robots):
    pty = folder / "pty"
    names = ["world_sim", "camera", "region_tracking", "feature_recognition", "fusion",
             "motor_bridge", "pilot", "teamcomm"]
    args = {"world_sim": f"[--pty-dir, {pty}, --outage, {OUTAGE_S}]",
            # The floor raster cache in the run's folder: the first start builds and writes it,
            # a restart reads it (services/camera/floor_raster_cache.hpp).
            "camera": f"[--field, msl, --raster-cache, {folder / 'raster_cache'}]",
            "feature_recognition": "[--field, msl]",
            "fusion": "[--field, msl]", "pilot": "[--steer, state, --scenario, default]",
            "motor_bridge": f'[--device, "{pty}/robot{{robot}}.tty"]'}
    text = ["# Generated by tests/integration/drills/drill.py: the first restart after 50 ms.",
            "defaults:", f"  robots: {robots}", "  restart: always", "  stop_grace_s: 2.0",
            "  backoff: {initial_s: 0.05, max_s: 10.0, stable_s: 2.0}",
            "  bus: {group: 239.255.76.67, base_port: 7667, ttl: 0, recv_buf_size: 4194304}",
            "processes:"]
    for name in names:
        exe, channel, bus = KINDS[name]
        text += [f"  - name: {name}", f"    executable: {exe}",
                 f"    robots: {'sim' if bus == 'sim' else 'all'}", f"    main_channel: {channel}"]
        if name in args:
            text.append(f"    args: {args[name]}")
    path = folder / "drill_team.yaml"
    path.write_text("\n".join(text) + "\n")
    return path


# The drill's launcher: only its own children are ever signalled (launcher_children.py says why).
LAUNCHER_PID = None


def find_pid(exe, bus):
    """Pid of the launcher's child running `exe` for robot 1 (or the simulator), or None."""
    return child_pid(LAUNCHER_PID, exe, robot=None if bus == "sim" else 1)


def start_time_us(pid):
    """When process `pid` was forked, us since the epoch (the kernel counts in 10 ms ticks)."""
    ticks = int(pathlib.Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[19])
    age_s = time.clock_gettime(time.CLOCK_BOOTTIME) - ticks / os.sysconf("SC_CLK_TCK")
    return now_us() - int(age_s * 1e6)


def wait_new_pid(exe, bus, old, timeout_s=15.0):
    """Polls every 5 ms for the restarted process: (pid, its start time in us) or (None, None)."""
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        pid = find_pid(exe, bus)
        if pid is not None and pid != old:
            try:
                return pid, start_time_us(pid)
            except OSError:
                pass  # ended again in between: look once more
        time.sleep(0.005)
    return None, None


def run(a):
    out = pathlib.Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    bin_ = pathlib.Path(a.bin)
    for cmd in ("ip link set lo up", "ip link set lo multicast on",
                "ip route add 224.0.0.0/4 dev lo"):
        subprocess.run(cmd.split(), check=True)
    plan = launch_file(out, 1)
    n_faults = {"kill": len(KINDS), "stop": 2, "serial": 1, "all": len(KINDS) + 3}[a.drill]
    budget = 60 + 10 + n_faults * (WAIT_S + 2) + 30
    launcher = subprocess.Popen(
        [bin_ / "fieldline-launch", plan, "--duration", str(int(budget)), "--no-table",
         "--status-period", "1"], stdout=open(out / "launch.log", "w"), stderr=subprocess.STDOUT)
    global LAUNCHER_PID
    LAUNCHER_PID = launcher.pid
    expect = [f"--expect={'sim' if b == 'sim' else 'r1'}/{k}" for k, (_, _, b) in KINDS.items()]
    probe = subprocess.run([bin_ / "fieldline-ready-probe", "--robots", "1", "--sim", "--timeout",
                            "60", *expect], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                           text=True)
    if probe.returncode != 0:
        print(probe.stdout)
        launcher.terminate()
        launcher.wait()
        print((out / "launch.log").read_text()[-3000:])
        sys.exit("FAIL: the team did not come up")
    channels = [c for _, c, b in KINDS.values() if b == "r1"] + ["SERVICE_STATUS"]
    dumps = [subprocess.Popen([bin_ / "fieldline-bus-dump", "--robot", "1", "--follow",
                               *[f"--channel={c}" for c in channels]],
                              stdout=open(out / "r1.jsonl", "w"), stderr=open(out / "r1.err", "w")),
             subprocess.Popen([bin_ / "fieldline-bus-dump", "--sim", "--follow",
                               "--channel=SIM_WORLD", "--channel=SERVICE_STATUS"],
                              stdout=open(out / "sim.jsonl", "w"), stderr=open(out / "sim.err", "w"))]
    events = []
    try:
        faults(a, Recording(out), events)
    finally:
        for d in dumps:
            d.send_signal(signal.SIGINT)
        for d in dumps:
            d.wait(timeout=10)
        launcher.terminate()
        rc = launcher.wait(timeout=30)
    (out / "events.json").write_text(json.dumps(events))
    (out / "run.json").write_text(json.dumps({"launcher_rc": rc}))
    if a.drill != "all":
        return analyse(out, events, rc)
    # The three drills' tests judge their own faults (--analyse-only); this run fails only when
    # one of them is missing (a fault that could not be applied ended the run).
    analyse(out, events, rc)
    missing = [d for d in DRILLS if not [e for e in events if drill_of(e) == d]]
    if missing:
        print(f"FAIL: no fault of {', '.join(missing)} applied")
        return 1
    print("the run is complete: the drills' tests judge it (drill.py DRILL --analyse-only)")
    return 0


DRILLS = ("kill", "stop", "serial")


def drill_of(ev):
    """Which drill an event belongs to (events of a run of one drill carry no name)."""
    return ev.get("group") or ("kill" if ev["drill"].startswith("kill") else
                               "stop" if ev["drill"].startswith("SIGSTOP") else "serial")


def faults(a, rec, events):
    """Applies the drill's faults one after another, appending what happened to `events`."""
    wait_baseline(rec)
    for drill in DRILLS if a.drill == "all" else (a.drill,):
        first = len(events)
        {"kill": kill_each, "stop": stop_each, "serial": cut_serial}[drill](rec, events)
        for ev in events[first:]:
            ev["group"] = drill


def kill_each(rec, events):
    for kind in KINDS:
        exe, channel, bus = KINDS[kind]
        pid = find_pid(exe, bus)
        if pid is None:
            sys.exit(f"FAIL: no {kind} process to kill")
        t_fault = now_us()
        os.kill(pid, signal.SIGKILL)
        new_pid, t_restart = wait_new_pid(exe, bus, pid)
        events.append({"drill": f"kill -9 {kind}", "kind": kind, "channel": channel,
                       "bus": bus, "t_fault": t_fault, "t_back": t_restart,
                       "restarted": new_pid is not None})
        wait_recovered(rec, events[-1])


def stop_each(rec, events):
    for kind, seconds in (("camera", STOP_S), ("region_tracking", STOP_TRACKING_S)):
        exe, channel, bus = KINDS[kind]
        pid = find_pid(exe, bus)
        if pid is None:
            sys.exit(f"FAIL: no {kind} process to stop")
        t_fault = now_us()
        os.kill(pid, signal.SIGSTOP)
        time.sleep(seconds)  # the fault itself: the process stopped
        os.kill(pid, signal.SIGCONT)
        events.append({"drill": f"SIGSTOP {kind} {seconds:.0f} s", "kind": kind,
                       "channel": channel, "bus": bus, "t_fault": t_fault, "t_back": now_us(),
                       "restarted": True})
        wait_recovered(rec, events[-1])


def cut_serial(rec, events):
    pid = find_pid("fieldline-world-sim", "sim")
    if pid is None:
        sys.exit("FAIL: no world_sim process")
    line = rec.out / "pty" / "robot1.tty"
    t_fault = now_us()
    os.kill(pid, signal.SIGUSR1)
    # The line is back when world_sim links a new pty at the device path (the bridge then
    # finds it on its next 0.25 s retry).
    while line.exists() and now_us() - t_fault < 5_000_000:
        time.sleep(0.002)
    t_gone = now_us()
    while not line.exists() and now_us() - t_fault < 15_000_000:
        time.sleep(0.002)
    events.append({"drill": f"serial line cut {OUTAGE_S:.0f} s", "kind": "motor_bridge",
                   "channel": "ODOMETRY", "bus": "r1", "t_fault": t_fault,
                   "t_back": now_us(), "restarted": line.exists(),
                   "line_gone_ms": round((t_gone - t_fault) / 1e3, 1)})
    wait_recovered(rec, events[-1])


def wait_baseline(rec):
    """Waits until BASELINE_S of estimates with truth and a status of fusion are recorded."""
    end = time.monotonic() + 20.0
    while time.monotonic() < end:
        rec.poll()
        t = now_us() - int(BASELINE_S * 1e6)
        if rec.errors(t - 500_000, t) and rec.status.get("fusion"):
            return
        time.sleep(0.05)
    # Without a baseline the first fault's "before" window would be empty and its jump check
    # would pass without looking at anything.
    sys.exit(f"FAIL: no {BASELINE_S:.0f} s of estimates with truth and fusion's status within 20 s")


def wait_recovered(rec, ev):
    """Waits until the recordings hold the fault's window (Recording.window_end); sets t_end."""
    end = ev["t_back"] + int(WAIT_S * 1e6) if ev["restarted"] else now_us()
    while now_us() < end:
        rec.poll()
        t_end = rec.window_end(ev)
        if t_end is not None and now_us() >= t_end:
            end = t_end
            break
        time.sleep(0.05)
    ev["t_end"] = end


class Recording:
    """The two bus recordings (robot 1's bus, the simulator's), read as fieldline-bus-dump writes
    them (poll) during a run, or whole for the analysis."""

    def __init__(self, out):
        self.out = out
        self.files = {"r1": open(out / "r1.jsonl"), "sim": open(out / "sim.jsonl")}
        self.partial = {"r1": "", "sim": ""}
        self.arrivals = {}   # (bus, channel) -> receive times
        self.truth = []      # robot 1's truth by simulated time: (utime, x, y)
        self.truth_t = []
        self.states = []     # ROBOT_STATE: (receive, utime, x, y, status)
        self.states_t = []
        self.status = {}     # process -> [(receive, SERVICE_STATUS)] of robot 1's bus
        self.camera_frames = []  # (receive, exposure utime)
        self.derived = []    # VISION_LINES and FIELD_FEATURES: (receive, frame utime)

    def poll(self, final=False):
        for bus, f in self.files.items():
            lines = (self.partial[bus] + f.read()).split("\n")
            self.partial[bus] = "" if final else lines.pop()
            for line in lines:
                self.add(bus, line)

    def add(self, bus, line):
        try:
            m = json.loads(line)
        except json.JSONDecodeError:
            return  # a line cut by the recorder's stop
        channel, recv, msg = m["channel"], m["receive_utime"], m["message"]
        self.arrivals.setdefault((bus, channel), []).append(recv)
        if bus == "sim":
            if channel == "SIM_WORLD":
                row = (msg["header"]["utime"], msg["robot_x"][0], msg["robot_y"][0])
                i = bisect.bisect(self.truth_t, row[0])
                self.truth.insert(i, row)
                self.truth_t.insert(i, row[0])
        elif channel == "ROBOT_STATE":
            self.states.append((recv, msg["header"]["utime"], msg["x"], msg["y"], msg["status"]))
            self.states_t.append(recv)
        elif channel == "SERVICE_STATUS":
            self.status.setdefault(msg["process"], []).append((recv, msg))
        elif channel == "CAMERA_IMAGE":
            self.camera_frames.append((recv, msg["header"]["utime"]))
        elif channel in ("VISION_LINES", "FIELD_FEATURES"):
            self.derived.append((recv, msg["header"]["utime"]))

    def true_at(self, utime):
        """Robot 1's true position at `utime` (same clock as robot 1's: no offset here)."""
        i = bisect.bisect_left(self.truth_t, utime)
        if i == 0 or i >= len(self.truth):
            return None
        (t0, x0, y0), (t1, x1, y1) = self.truth[i - 1], self.truth[i]
        if t1 - t0 > 50_000:  # no truth around this time (the simulator was away)
            return None
        w = (utime - t0) / (t1 - t0)
        return x0 + w * (x1 - x0), y0 + w * (y1 - y0)

    def errors(self, t_from, t_to):
        """(receive time, error vector, status) of every ROBOT_STATE received in [t_from, t_to)."""
        result = []
        lo, hi = bisect.bisect_left(self.states_t, t_from), bisect.bisect_left(self.states_t, t_to)
        for recv, utime, x, y, status in self.states[lo:hi]:
            tr = self.true_at(utime)
            if tr is not None:
                result.append((recv, (x - tr[0], y - tr[1]), status))
        return result

    def after(self, ev):
        """Arrivals of the fault's channel from the restart (or resume) on."""
        times = self.arrivals.get((ev["bus"], ev["channel"]), [])
        return times[bisect.bisect_left(times, ev["t_back"]):]

    def full_rate(self, ev, after):
        """The first arrival from which the next second holds RATE_SHARE of the nominal rate."""
        nominal = NOMINAL_HZ[ev["channel"]]
        for k, t in enumerate(after):
            j = bisect.bisect_left(after, t + 1_000_000)
            if j == len(after) and after[-1] < t + 1_000_000 - 50_000:
                return None  # the recording ends within this second
            if j - k >= RATE_SHARE * nominal:
                return t
        return None

    def converged(self, t_back, t_to):
        """A restarted fusion's first estimate within JUMP_LIMIT_M of the truth, TRACKING."""
        return next((r for r, e, s in self.errors(t_back, t_to)
                     if math.hypot(*e) < JUMP_LIMIT_M and s == 2), None)

    def window_end(self, ev):
        """When the fault's measurement window may end, or None while the recordings lack a part
        of it: the rate second, the reach of the fault (+0.5 s), the statuses read after it."""
        after = self.after(ev)
        full = self.full_rate(ev, after) if after else None
        if full is None:
            return None
        end = max(full + 1_050_000, after[0] + int((FAULT_REACH_S + 0.5) * 1e6))
        if ev["kind"] == "fusion":
            conv = self.converged(ev["t_back"], now_us())
            if conv is None:
                return None
            end = max(end, conv + int((FAULT_REACH_S + 0.5) * 1e6))
        if "line_gone_ms" in ev:  # the bridge's reconnect count, read 2 s after the line is back
            bridge = [r for r, _ in self.status.get("motor_bridge", []) if r >= ev["t_back"] + 2e6]
            if not bridge:
                return None
            end = max(end, bridge[0] + 50_000)
        # The fusion status that closes the window (read in its last 1.5 s).
        closing = [r for r, _ in self.status.get("fusion", []) if r >= end - 1_000_000]
        if not closing:
            return None
        return max(end, closing[0] + 50_000)


def metric(status, name):
    return dict(zip(status["metric_name"], status["metric_value"])).get(name, 0.0)


def analyse(out, events, launcher_rc):
    rec = Recording(out)
    rec.poll(final=True)
    errors, fusion_status = rec.errors, rec.status.get("fusion", [])
    bridge_status = rec.status.get("motor_bridge", [])
    failures = []
    results = []
    for ev in events:
        res = {"drill": ev["drill"], "channel": ev["channel"]}
        t_fault, t_back = ev["t_fault"], ev["t_back"]
        if not ev["restarted"]:
            failures.append(f"{ev['drill']}: the process did not come back")
            results.append(res)
            continue
        res["fault_to_restart_ms"] = round((t_back - t_fault) / 1e3, 1)
        # The end of the fault's window: where the drill's wait ended (a fixed 6 s before).
        t_end = ev.get("t_end", t_back + 6_000_000)
        nominal = NOMINAL_HZ[ev["channel"]]
        after = rec.after(ev)
        res["restart_to_first_ms"] = round((after[0] - t_back) / 1e3, 1) if after else None
        full = rec.full_rate(ev, after)
        res["restart_to_full_rate_ms"] = round((full - t_back) / 1e3, 1) if full else None
        if full and after:
            res["first_to_full_rate_ms"] = round((full - after[0]) / 1e3, 1)
        if full is None or full - t_back > RATE_BOUND_S * 1e6:
            failures.append(f"{ev['drill']}: {ev['channel']} not back at {RATE_SHARE:.0%} of "
                            f"{nominal} Hz within {RATE_BOUND_S} s of the restart")
        # The estimate: from 3 s before the fault to the end of its window.
        before = errors(t_fault - 3_000_000, t_fault)
        during = errors(t_fault, t_end - 500_000)
        res["window_ms"] = round((t_end - t_back) / 1e3, 1)
        res["error_before_max_m"] = round(max((math.hypot(*e) for _, e, _ in before),
                                              default=float("nan")), 3)
        if ev["kind"] == "fusion":
            # A new fusion starts from its start-up prior: measure the time until it tracks
            # within 20 cm again, and the steps after that.
            conv = next((r for r, e, s in during if r >= t_back and math.hypot(*e) < JUMP_LIMIT_M
                         and s == 2), None)
            res["restart_to_converged_ms"] = round((conv - t_back) / 1e3, 1) if conv else None
            if conv is None:
                failures.append(f"{ev['drill']}: fusion did not re-converge within 20 cm")
                during = []
            else:
                during = [d for d in during if d[0] >= conv]
        # A step away from the truth between two consecutive estimates: what a stale or wrongly
        # timed measurement does. Steps toward the truth are vision corrections doing their job.
        prev = before[-1] if before and ev["kind"] != "fusion" else None
        # The reach counts from the restarted process's first message (a slow start-up delays
        # its stale inputs too), for fusion from its convergence.
        reach = (after[0] if after else t_back) + int(FAULT_REACH_S * 1e6)
        if ev["kind"] == "fusion" and during:
            reach = max(reach, during[0][0] + int(FAULT_REACH_S * 1e6))
        jump = 0.0
        settle_jump, settle_at = 0.0, None
        for d in during:
            if prev is not None:
                step = math.hypot(*d[1]) - math.hypot(*prev[1])
                if d[0] < reach:
                    jump = max(jump, step)
                if step > settle_jump:
                    settle_jump, settle_at = step, d[0]
            prev = d
        res["max_jump_m"] = round(jump, 3)
        res["max_jump_settle_m"] = round(settle_jump, 3)
        if settle_at is not None:
            res["max_jump_settle_at_ms"] = round((settle_at - t_back) / 1e3, 1)
        res["error_after_max_m"] = round(max((math.hypot(*e) for _, e, _ in during),
                                             default=float("nan")), 3)
        if not during:
            failures.append(f"{ev['drill']}: no ROBOT_STATE with truth after the fault")
        elif jump > JUMP_LIMIT_M and ev["kind"] != "world_sim":
            failures.append(f"{ev['drill']}: the estimate jumped {jump:.3f} m against the truth")
        if ev["kind"] == "camera":
            # Frames published after the resume whose exposure is older than fusion's window
            # (1 s): fusion must refuse them, never fuse them.
            stale = [(r, u) for r, u in rec.camera_frames if t_back <= r < t_end and r - u > 1_000_000]
            res["stale_frames_after_resume"] = len(stale)
            res["max_frame_age_after_resume_ms"] = round(max(
                (r - u for r, u in rec.camera_frames if t_back <= r < t_back + 2_000_000),
                default=0) / 1e3, 1)
        pre = [s for r, s in fusion_status if r < t_fault]
        # The status at the end of this fault's window (not a later fault's).
        post = [s for r, s in fusion_status if t_end - 1_500_000 <= r < t_end]
        refused = {}
        if pre and post and ev["kind"] != "fusion":
            def counts(s):
                return dict(zip(s["error_kind"], s["error_count"]))
            a, b = counts(pre[-1]), counts(post[-1])
            refused = {k: v - a.get(k, 0) for k, v in b.items() if v != a.get(k, 0)}
            res["fusion_refusals"] = refused
            res["fusion_slips"] = metric(post[-1], "slips") - metric(pre[-1], "slips")
        if ev["drill"].startswith("SIGSTOP"):
            # Lines and features of the frames exposed before the stop reach fusion after the
            # resume, older than its window: each must be refused (counted), never fused.
            # Within this fault's window: a later fault of the shared run (drill.py all) is not this one's.
            stale = [1 for r, u in rec.derived if t_back <= r < t_end and r - u > 1_000_000]
            res["stale_lines_features_after_resume"] = len(stale)
            n_refused = refused.get("lines_too_old", 0) + refused.get("features_too_old", 0)
            if not pre or not post:
                failures.append(f"{ev['drill']}: no SERVICE_STATUS of fusion around the stop")
            elif stale and n_refused == 0:
                failures.append(f"{ev['drill']}: {len(stale)} stale lines/features after the "
                                f"resume and fusion refused none of them")
            elif not stale and ev["kind"] == "region_tracking":
                # This stop exists to send fusion stale lines; without them it checked nothing.
                failures.append(f"{ev['drill']}: no lines/features older than 1 s after the "
                                f"resume (the check of their refusal did not run)")
        if ev["kind"] == "motor_bridge" and "line_gone_ms" in ev:
            res["line_gone_ms"] = ev["line_gone_ms"]
            pre_b = [s for r, s in bridge_status if r < t_fault]
            post_b = [s for r, s in bridge_status if r >= t_back + 2_000_000]
            gained = (metric(post_b[-1], "serial_reconnects") - metric(pre_b[-1], "serial_reconnects")
                      if pre_b and post_b else 0)
            res["bridge_reconnects"] = gained
            if gained < 1:
                failures.append(f"{ev['drill']}: the motor bridge did not report a reconnect")
        results.append(res)
    if launcher_rc != 0:
        failures.append(f"launcher exit code {launcher_rc}")
    for res in results:
        print("RESULT", json.dumps(res))
    for f in failures:
        print("FAIL:", f)
    print("PASS" if not failures else f"{len(failures)} failures")
    return 1 if failures else 0


def main():
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("drill", choices=["kill", "stop", "serial", "all"])
    p.add_argument("--bin", required=True, help="folder of the fieldline executables")
    p.add_argument("--out", required=True, help="folder for the launch file and recordings")
    p.add_argument("--analyse-only", action="store_true",
                   help="analyse the recordings of an earlier run in --out")
    a = p.parse_args()
    if a.analyse_only:
        out = pathlib.Path(a.out)
        if not (out / "events.json").exists():
            sys.exit(f"FAIL: no events.json in {out} (the run failed or did not happen)")
        events = json.loads((out / "events.json").read_text())
        if a.drill != "all":
            events = [e for e in events if drill_of(e) == a.drill]
            if not events:
                sys.exit(f"FAIL: no fault of the {a.drill} drill in {out}")
        run_file = out / "run.json"
        rc = json.loads(run_file.read_text())["launcher_rc"] if run_file.exists() else 0
        sys.exit(analyse(out, events, rc))
    sys.exit(run(a))


if __name__ == "__main__":
    main()
