#!/usr/bin/env bash
# Runs one drill of drill.py in a private network namespace: BIN ROOT OUT DRILL.
set -u
bin=$1 root=$2 out=$3 drill=$4
export FIELDLINE_ROOT="$root"
rm -rf "$out"
mkdir -p "$out"
# A private mount namespace too, with its own /tmp/fieldline (the simulator's pseudo-terminals,
# its snapshot and fusion's pose files), which every team on the machine would share otherwise.
ns="unshare -n -m --propagation private"
$ns true 2>/dev/null || ns="unshare -r -n -m --propagation private"
exec $ns bash -c 'mkdir -p /tmp/fieldline && mount -t tmpfs tmpfs /tmp/fieldline &&
  exec python3 "$1/tests/integration/drills/drill.py" "$2" --bin "$3" --out "$4"' \
  run_drill "$root" "$drill" "$bin" "$out"
