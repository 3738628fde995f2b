#!/bin/sh
# The house rules on includes (docs/design.md, "Layers"), checked on every C++ file:
#   1. a service never includes another service: services/X includes nothing from services/Y
#      (shared code lives in common/; test helpers in tests/support);
#   2. common/ includes nothing from services/ or tools/;
#   3. generated message headers (<fieldline/..._t.hpp>) only in node files (*_node.*), mains
#      (main.cpp, *_main.cpp), common/bus, common/msg, tools/, tests/ and bench/: everything
#      else works on the plain structs of common/perception, converted in common/msg;
#   4. test support stays in tests: nothing in common/, services/, teamcomm/ or tools/ includes a
#      file under tests/, and no CMakeLists.txt there links or names a test target or directory
#      (rendered frames for tools live in tools/sim_frames);
#   5. CLI11 only in common/cli/cli.cpp: every other file uses the compiled front end
#      common/cli/cli.hpp (CLI11 costs about 10 CPU-s in each file that includes it).
# Prints every violation as file:line: text and exits 1 if there is one.
# usage: include_rules.sh [REPO_ROOT]
set -eu
cd "${1:-.}"

# Known offenders being fixed, each with the reason (none today).
exceptions=''

status=0
# Prints the lines of file $1 that match $2 (a grep pattern), minus those matching $3, as
# file:line: text (why); sets status when there are any.
check() {
  hits=$(grep -n "$2" "$1" | grep -v "$3" || true)
  if [ -n "$hits" ]; then
    echo "$hits" | sed "s|^|$1:|; s|\$|  ($4)|"
    status=1
  fi
}
include='^[[:space:]]*#[[:space:]]*include[[:space:]]*'

files=$(find common services tools tests bench teamcomm -name '*.cpp' -o -name '*.hpp' 2>/dev/null | sort)
for f in $files; do
  case " $exceptions " in *" $f "*) continue ;; esac
  case $f in
    services/*)
      own=$(echo "$f" | cut -d/ -f2)
      check "$f" "$include\"services/" "\"services/$own/" "a service includes another service"
      ;;
    teamcomm/*) check "$f" "$include\"services/" '^$' "teamcomm includes a service" ;;
    common/*) check "$f" "$include\"\(services\|tools\)/" '^$' "common includes a service or tool" ;;
  esac
  case $f in
    common/* | services/* | teamcomm/* | tools/*)
      check "$f" "$include\"tests/" '^$' "test support included outside tests"
      ;;
  esac
  case $f in
    common/cli/cli.cpp) ;;
    *) check "$f" "$include<CLI/" '^$' "CLI11 outside common/cli (use common/cli/cli.hpp)" ;;
  esac
  case $f in
    common/bus/* | common/msg/* | tools/* | tests/* | bench/*) continue ;;
  esac
  case $(basename "$f") in
    *_node.hpp | *_node.cpp | main.cpp | *_main.cpp) continue ;;
  esac
  check "$f" "$include<fieldline/.*_t\.hpp>" '^$' "message header outside node, main, common/bus, common/msg"
done
# The build files: a library or executable outside tests/ never links test support.
cmake_files=$(find common services tools teamcomm -name CMakeLists.txt 2>/dev/null | sort)
for f in $cmake_files; do
  check "$f" 'test_support\|tests/' '^[0-9]*:[[:space:]]*#' "test support linked outside tests"
done
[ $status -eq 0 ] && echo "include rules: $(echo "$files" | wc -w) files clean"
exit $status
