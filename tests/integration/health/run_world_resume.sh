#!/usr/bin/env bash
# Runs world_resume.py in a private network namespace: BIN ROOT OUT [world_resume.py options].
set -u
bin=$1 root=$2 out=$3
shift 3
export FIELDLINE_ROOT="$root"
rm -rf "$out"
mkdir -p "$out"
ns="unshare -n"
unshare -n true 2>/dev/null || ns="unshare -rn"
exec $ns python3 "$root/tests/integration/health/world_resume.py" --bin "$bin" --out "$out" "$@"
