#!/usr/bin/env bash
# Runs world_resume.py in a private network namespace: BIN ROOT OUT [world_resume.py options].
set -u
bin=$1 root=$2 out=$3
shift 3
export FIELDLINE_ROOT="$root"
rm -rf "$out"
mkdir -p "$out"
# Private network and mount namespaces: its own buses and its own /tmp/fieldline (the simulator's
# serial lines and snapshot, fusion's pose files), not a running demo's.
ns="unshare -n -m --propagation private"
$ns true 2>/dev/null || ns="unshare -r -n -m --propagation private"
exec $ns bash -c 'mkdir -p /tmp/fieldline && mount -t tmpfs tmpfs /tmp/fieldline &&
  exec python3 "$1/tests/integration/health/world_resume.py" --bin "$2" --out "$3" "${@:4}"' \
  run_world_resume "$root" "$bin" "$out" "$@"
