#!/usr/bin/env bash
# Measures whether ten WebSocket clients of fieldline-viewer slow the robots' processes: the
# six-robot simulated team in a private network namespace, SERVICE_STATUS of every robot for
# SECONDS without clients, then for SECONDS with ten clients reading /ws (20 Hz state documents),
# then the median latency (p50, p95) and rate of each output channel in both periods.
#
#   tests/integration/viewer/measure_clients.sh build/bin [SECONDS]     # writes to stdout
set -eu
# Its own buses and /tmp/fieldline: never a running demo's serial lines, snapshot or pose files.
. "$(dirname "$0")/../lib/private_ns.sh" "$@"
bin=$(realpath "$1")
seconds=${2:-15}
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../../.." && pwd)
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
bash -c "
  export FIELDLINE_ROOT='$root'
  '$bin/fieldline-launch' sim_team --duration $((seconds * 2 + 40)) --no-table \
      > '$out/launch.log' 2>&1 &
  launcher=\$!
  sleep 25  # every robot localizing
  dump() {
    pids=
    for r in 1 2 3 4 5 6; do
      '$bin/fieldline-bus-dump' --robot \$r --channel SERVICE_STATUS --duration $seconds \
          > '$out/'\$1_\$r.jsonl 2>/dev/null &
      pids=\"\$pids \$!\"
    done
    wait \$pids
  }
  dump without
  python3 '$here/ws_clients.py' 8080 10 $((seconds + 2)) > '$out/clients.txt' &
  clients=\$!
  sleep 1
  dump with
  wait \$clients
  kill -TERM \$launcher; wait \$launcher || true
"
cat "$out/clients.txt"
python3 - "$out" <<'PY'
import glob, json, statistics, sys
out = sys.argv[1]
def load(period):
    by_channel = {}
    for path in glob.glob(f"{out}/{period}_*.jsonl"):
        for line in open(path):
            m = json.loads(line)["message"]
            for i, ch in enumerate(m["channel"]):
                if m["direction"][i] != 1 or m["rate_hz"][i] <= 0:
                    continue
                e = by_channel.setdefault(ch, {"p50": [], "p95": [], "rate": []})
                e["p50"].append(m["latency_p50_ms"][i])
                e["p95"].append(m["latency_p95_ms"][i])
                e["rate"].append(m["rate_hz"][i])
    return by_channel
without, with_ = load("without"), load("with")
print("| channel | p50 latency ms without / with | p95 latency ms without / with | rate Hz without / with |")
print("|---|---|---|---|")
for ch in sorted(without):
    if ch not in with_:
        continue
    a, b = without[ch], with_[ch]
    med = statistics.median
    print(f"| {ch} | {med(a['p50']):.2f} / {med(b['p50']):.2f} | {med(a['p95']):.2f} / "
          f"{med(b['p95']):.2f} | {med(a['rate']):.1f} / {med(b['rate']):.1f} |")
PY
