#!/usr/bin/env bash
# Red-team finding 8 (issue 34) for the team link's own settings: `fieldline-teamcomm
# --check-args` (what the launcher's --dry-run and every start run) refuses a multicast group
# that is not an address (239.255.76.999 passed and then crash-looped), the local network control
# block (224.0.0.1 passed silently), a bus on the team port, and warns about ttl 255 (passed
# silently). Failed on main at 32dcf7a: 239.255.76.999, 224.0.0.1 and the bus on the team port
# exited 0, ttl 255 said nothing.
#
#   redteam_settings.sh BIN_DIR SOURCE_DIR
set -u
bin=$1
root=$2
export FIELDLINE_ROOT="$root"
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
failures=0

# A copy of the simulated team's link with one transport line changed.
team_file() {  # NAME SED_EXPRESSION
  sed "$2" "$root/config/team/sim_team.yaml" > "$dir/$1.yaml"
  echo "$dir/$1.yaml"
}

expect() {  # WHAT EXPECTED_CODE PATTERN ARGS...
  local what=$1 code=$2 pattern=$3
  shift 3
  "$bin/fieldline-teamcomm" --robot 1 "$@" --check-args > "$dir/out" 2>&1
  local got=$?
  if [ "$got" != "$code" ] || { [ -n "$pattern" ] && ! grep -q -- "$pattern" "$dir/out"; }; then
    echo "FAIL: $what: exit code $got (expected $code), output:"
    cat "$dir/out"
    failures=$((failures + 1))
  else
    echo "ok: $what: exit code $got${pattern:+: $(grep -m1 -- "$pattern" "$dir/out" | cut -c1-200)}"
  fi
}

expect "group 239.255.76.999" 2 "is not an IPv4 address" \
  --team-config "$(team_file bad_group 's/group: 239.255.76.100/group: 239.255.76.999/')"
expect "group 224.0.0.1" 2 "local network control block" \
  --team-config "$(team_file all_hosts 's/group: 239.255.76.100/group: 224.0.0.1/')"
expect "group 10.0.0.1" 2 "is not a multicast group" \
  --team-config "$(team_file unicast_group 's/group: 239.255.76.100/group: 10.0.0.1/')"
expect "ttl 255" 0 "ttl 255 lets team packets cross 254 router" \
  --team-config "$(team_file ttl 's/ttl: 1$/ttl: 255/')"
expect "bus on the team port" 2 "is this robot's bus port too" \
  --team-config sim_team --bus-url "udpm://239.255.76.67:47600?ttl=0"
expect "the shipped team config" 0 "" --team-config sim_team
[ "$failures" = 0 ] && echo PASS || { echo "FAIL: $failures check(s)"; exit 1; }
