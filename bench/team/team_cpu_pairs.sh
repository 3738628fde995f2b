#!/usr/bin/env bash
# Two builds of the robot executables compared in the same simulated team, so that the host's
# speed, which changes by the minute on a shared machine, cancels out:
#
#   bench/team/team_cpu_pairs.sh OLD_BIN NEW_BIN OUT PAIRS EXE...
#   bench/team/team_cpu_pairs.sh ../old/build/bin build/bin /tmp/pairs 2 camera fusion
#
# Each pair is two runs of bench/team/team_cpu.sh (10 s warm-up, 30 s window): OLD_BIN's
# fieldline-EXE on robots 1-3 and NEW_BIN's (copied as fieldline-EXE-new) on 4-6, then swapped;
# everything else (simulator, viewer, the executables not named) from OLD_BIN. Robots 4-6 can cost
# a few per cent more than 1-3 for some executables, so only a swapped pair's sums compare builds.
# Prints, per run, CPU per message of each EXE on both sides (camera, region tracking and feature
# recognition 30 a second, pilot and motor bridge 50, fusion ~180 inputs; the team link per
# robot) and per pair new / old. With LIVE_LOCK=FILE each run holds `flock FILE` (one team at a
# time on a machine shared by several people). Runs and launch files stay in OUT.
set -euo pipefail
if [ $# -lt 5 ]; then
  sed -n '2,14p' "$0" >&2
  exit 2
fi
old=$(realpath "$1") new=$(realpath "$2") out=$(realpath -m "$3") pairs=$4
shift 4
root=$(cd "$(dirname "$0")/../.." && pwd)
for exe in "$@"; do
  [ -x "$new/fieldline-$exe" ] || { echo "team_cpu_pairs: no $new/fieldline-$exe" >&2; exit 2; }
done
bin=$out/team/bin
rm -rf "$out/team"
mkdir -p "$bin" "$out/team/share/fieldline"
for f in "$old"/*; do ln -s "$f" "$bin/"; done
# The launcher looks for executables beside its resolved self: a copy, not a link.
rm "$bin/fieldline-launch"
cp "$old/fieldline-launch" "$bin/"
for exe in "$@"; do cp "$new/fieldline-$exe" "$bin/fieldline-$exe-new"; done
for d in config services tests; do ln -s "$root/$d" "$out/team/share/fieldline/$d"; done
ln -s "$root/tools/viewer/web" "$out/team/share/fieldline/web"
for half in a b; do python3 "$root/bench/team/team_cpu_mix.py" "$root" $half "$@" > "$out/mixed_$half.yaml"; done
lock=()
[ -n "${LIVE_LOCK:-}" ] && lock=(flock "$LIVE_LOCK")
for i in $(seq 1 "$pairs"); do
  for half in a b; do
    echo "pair $i, run $half: $(date -u +%T), load $(cut -d' ' -f1 /proc/loadavg)" > "$out/$i-$half.txt"
    if ! TEAM_CPU_WAKEUPS=1 "${lock[@]}" bash "$root/bench/team/team_cpu.sh" "$out/mixed_$half.yaml" 30 "$bin" >> "$out/$i-$half.txt" 2>&1; then
      echo "team_cpu_pairs: run $i-$half failed:" >&2
      tail -20 "$out/$i-$half.txt" >&2
      exit 1
    fi
  done
done
python3 - "$out" <<'PY'
import glob, os, re, sys
rates = {"camera": 30, "region-tracking": 30, "feature-recognition": 30, "pilot": 50,
         "motor-bridge": 50, "fusion": 180, "teamcomm": None}
sums = {}
for f in sorted(glob.glob(sys.argv[1] + "/*-[ab].txt")):
    text = open(f).read()
    cpu = {m[1]: float(m[2]) for m in re.finditer(r"fieldline-(\S+?)\s+([\d.]+) cpu-s/s", text)}
    print(text.splitlines()[0], " total", re.search(r"total\s+([\d.]+)", text)[1])
    pair = os.path.basename(f).split("-")[0]
    for exe, rate in rates.items():
        if exe not in cpu or exe + "-new" not in cpu:
            continue
        a, b = cpu[exe], cpu[exe + "-new"]
        s = sums.setdefault((pair, exe), [0.0, 0.0])
        s[0] += a
        s[1] += b
        unit = (lambda x: f"{x / 3 / rate * 1000:.3f} ms a message") if rate else \
               (lambda x: f"{x / 3:.4f} CPU-s/s a robot")
        print(f"  {exe:20s} old {unit(a)}, new {unit(b)}")
for (pair, exe), (a, b) in sorted(sums.items()):
    print(f"pair {pair} {exe}: new / old {b / a:.3f}")
PY
