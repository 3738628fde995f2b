#!/usr/bin/env bash
# Runs one drill of drill.py in a private network namespace: BIN ROOT OUT DRILL.
set -u
bin=$1 root=$2 out=$3 drill=$4
export FIELDLINE_ROOT="$root"
rm -rf "$out"
mkdir -p "$out"
ns="unshare -n"
unshare -n true 2>/dev/null || ns="unshare -rn"
exec $ns python3 "$root/tests/integration/drills/drill.py" "$drill" --bin "$bin" --out "$out"
