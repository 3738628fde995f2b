# For a test script that starts processes: its own buses and its own /tmp/fieldline. Source it
# first thing with the script's arguments:
#
#   . "$(dirname "$0")/../lib/private_ns.sh" "$@"
#
# Outside, it runs the script again (bash) in private network and mount namespaces (root's, or
# in a user namespace without root) and does not return; inside, it brings loopback up with
# multicast and the 224.0.0.0/4 route, and mounts a tmpfs of its own on /tmp/fieldline (the
# simulator's serial lines and snapshot, fusion's pose files), so a test run beside a running
# demo neither hears its buses nor takes its files. FIELDLINE_PRIVATE_NS marks the inside.
if [ -z "${FIELDLINE_PRIVATE_NS:-}" ]; then
  export FIELDLINE_PRIVATE_NS=1
  if unshare -n -m --propagation private true 2>/dev/null; then
    exec unshare -n -m --propagation private bash "$0" "$@"
  elif unshare -r -n -m --propagation private true 2>/dev/null; then
    exec unshare -r -n -m --propagation private bash "$0" "$@"
  fi
  echo "FAIL: cannot create network and mount namespaces (run as root, or allow unprivileged" \
    "user namespaces)"
  exit 1
fi
ip link set lo up
ip link set lo multicast on
ip route add 224.0.0.0/4 dev lo
mkdir -p /tmp/fieldline && mount -t tmpfs tmpfs /tmp/fieldline ||
  { echo "FAIL: cannot mount a private /tmp/fieldline"; exit 1; }
