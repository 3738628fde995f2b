# Shared by the team-link tests: a bridge in the relay's network namespace (the access point
# stand-in) and robots joined to it by veth pairs. Source it; needs root (ip netns).

# team_net_bridge RELAY_NS: the relay's namespace with bridge br0 at 10.20.0.100/24.
team_net_bridge() {
  ip netns add "$1" || { echo "cannot create network namespaces (needs root)"; return 1; }
  ip -n "$1" link set lo up
  ip -n "$1" link add br0 type bridge
  ip -n "$1" link set br0 up
  ip -n "$1" addr add 10.20.0.100/24 dev br0
}

# team_net_join NS ADDRESS RELAY_NS: a new namespace whose eth0 (ADDRESS/24) is a port of the
# relay's bridge; multicast on its loopback carries the robot's own LCM bus.
team_net_join() {
  ip netns add "$1"
  ip link add eth0 netns "$1" type veth peer name "p_$1" netns "$3"
  ip -n "$3" link set "p_$1" master br0
  ip -n "$3" link set "p_$1" up
  ip -n "$1" link set lo up
  ip -n "$1" link set lo multicast on
  ip -n "$1" route add 224.0.0.0/4 dev lo
  ip -n "$1" addr add "$2/24" dev eth0
  ip -n "$1" link set eth0 up
}

# team_net_remove NS...: kills what runs in each namespace and deletes it.
team_net_remove() {
  local ns
  for ns in "$@"; do
    ip netns pids "$ns" 2>/dev/null | xargs -r kill 2>/dev/null
    ip netns del "$ns" 2>/dev/null
  done
  return 0
}
