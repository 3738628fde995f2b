# Waiting for a condition instead of for a time (tests/CMakeLists.txt). Source it.
#
#   wait_for 30 "robot 1's pseudo-terminal" test -e "$dir/pty/robot1.tty"
#
# wait_for SECONDS WHAT COMMAND...: runs COMMAND every 0.1 s until it succeeds (return 0) or
# SECONDS have passed (return 1, after saying on stderr what did not happen). The deadline is
# only the failure bound: a quick condition returns at once, a loaded machine gets the time.
wait_for() {
  local seconds=$1 what=$2
  shift 2
  local deadline=$(($(date +%s%N) + ${seconds%.*} * 1000000000))
  until "$@" > /dev/null 2>&1; do
    if [ "$(date +%s%N)" -ge "$deadline" ]; then
      echo "timed out after ${seconds} s waiting for $what" >&2
      return 1
    fi
    sleep 0.1
  done
}
