#!/usr/bin/env bash
# scripts/test's short fuzzing round, as ctest tests (tests/CMakeLists.txt, label `fuzz`), so that
# it runs in ctest's free slots beside the team tests instead of after them:
#   ctest_round.sh build DIR          builds the libFuzzer targets (clang, ASan + UBSan) in DIR
#                                     with one job at nice 10 (scripts/fuzz, FUZZ_STEP=build)
#   ctest_round.sh run DIR TARGET     the seed check, then TARGET for FUZZ_SECONDS (default 10)
# Exit 77 (ctest: skipped) without clang++ or with FUZZ_SECONDS=0.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
step=${1:-}
dir=${2:-}
seconds=${FUZZ_SECONDS:-10}
if [ "$seconds" = 0 ]; then
  echo "SKIP: FUZZ_SECONDS=0"
  exit 77
fi
if ! command -v clang++ >/dev/null 2>&1; then
  echo "SKIP: clang++ is not installed (scripts/setup installs clang)"
  exit 77
fi
case $step in
  build) FUZZ_STEP=build JOBS=1 FUZZ_BUILD_DIR=$dir exec "$root/scripts/fuzz" "$seconds" ;;
  run) FUZZ_STEP=run JOBS=1 FUZZ_TARGETS=${3:?target} FUZZ_BUILD_DIR=$dir exec "$root/scripts/fuzz" "$seconds" ;;
  *)
    echo "usage: ctest_round.sh build DIR | run DIR TARGET" >&2
    exit 2
    ;;
esac
