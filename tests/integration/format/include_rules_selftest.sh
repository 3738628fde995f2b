#!/bin/sh
# include_rules.sh must catch each kind of violation and pass a clean tree: runs it on small
# made-up trees. usage: include_rules_selftest.sh PATH/TO/include_rules.sh
set -u
rules=$1
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
failures=0

# expect EXIT_CODE NAME: runs the rules on $dir/tree and compares the exit code.
expect() {
  sh "$rules" "$dir/tree" >"$dir/out" 2>&1
  rc=$?
  if [ "$rc" -ne "$1" ]; then
    echo "FAIL: $2: exit $rc, expected $1"
    cat "$dir/out"
    failures=$((failures + 1))
  else
    echo "ok: $2"
  fi
}
fresh() {
  rm -rf "$dir/tree"
  mkdir -p "$dir/tree/services/a" "$dir/tree/services/b" "$dir/tree/common/x" "$dir/tree/tools/t"
  echo '#include "services/a/own.hpp"' >"$dir/tree/services/a/lib.cpp"
  echo '#include "common/x/x.hpp"' >"$dir/tree/services/a/other.cpp"
  echo '#include <fieldline/odometry_t.hpp>' >"$dir/tree/services/a/a_node.cpp"
  echo '#include <fieldline/odometry_t.hpp>' >"$dir/tree/services/a/main.cpp"
  echo '#include "services/b/b.hpp"' >"$dir/tree/tools/t/main.cpp"
}

fresh
expect 0 "a clean tree passes"
fresh
echo '#include "services/b/b.hpp"' >>"$dir/tree/services/a/lib.cpp"
expect 1 "a service including another service"
fresh
echo '#include "services/a/own.hpp"' >"$dir/tree/common/x/x.cpp"
expect 1 "common including a service"
fresh
echo '#include <fieldline/image_t.hpp>' >"$dir/tree/services/a/lib.hpp"
expect 1 "a message header in a library file"
fresh
mkdir -p "$dir/tree/common/msg"
echo '#include <fieldline/image_t.hpp>' >"$dir/tree/common/msg/image.hpp"
expect 0 "a message header in common/msg"
fresh
echo '#include "tests/support/sim_frames.hpp"' >>"$dir/tree/tools/t/main.cpp"
expect 1 "a tool including test support"
fresh
echo 'target_link_libraries(t PRIVATE fieldline_test_support)' >"$dir/tree/tools/t/CMakeLists.txt"
expect 1 "a tool linking the test-support library"
fresh
echo 'add_subdirectory(${PROJECT_SOURCE_DIR}/tests/support support)' >"$dir/tree/tools/t/CMakeLists.txt"
expect 1 "a tool building test support"
fresh
echo 'target_link_libraries(t PRIVATE fieldline_sim_frames)' >"$dir/tree/tools/t/CMakeLists.txt"
expect 0 "a tool linking the simulated frames library"
fresh
echo '#include <CLI/CLI.hpp>' >>"$dir/tree/tools/t/main.cpp"
expect 1 "CLI11 outside common/cli"
fresh
mkdir -p "$dir/tree/common/cli"
echo '#include <CLI/CLI.hpp>' >"$dir/tree/common/cli/cli.cpp"
expect 0 "CLI11 in common/cli/cli.cpp"

[ "$failures" -eq 0 ]
