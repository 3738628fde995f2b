#!/usr/bin/env bash
# A bus without a multicast route fails with a clear remedy (exit 3); with the route it works.
# Runs in private network namespaces so it never touches the machine's network, and private mount
# namespaces with their own /tmp/fieldline (as every test script that starts a process).
set -u
check=$1
# Root gets plain namespaces; without root a user namespace provides them.
ns="unshare -n -m --propagation private"
$ns true 2>/dev/null || ns="unshare -r -n -m --propagation private"
private_tmp="mkdir -p /tmp/fieldline && mount -t tmpfs tmpfs /tmp/fieldline"
out=$($ns sh -c "$private_tmp; ip link set lo up; '$check' --robot 2" 2>&1)
rc=$?
echo "$out"
if [ $rc -ne 3 ]; then echo "FAIL: expected exit 3 without a route, got $rc"; exit 1; fi
case "$out" in
  *"ip route replace 224.0.0.0/4 dev lo"*) ;;
  *) echo "FAIL: the error does not say what to run"; exit 1 ;;
esac
out=$($ns sh -c "$private_tmp; ip link set lo up; ip link set lo multicast on; ip route add 224.0.0.0/4 dev lo; '$check' --robot 2" 2>&1)
rc=$?
echo "$out"
if [ $rc -ne 0 ]; then echo "FAIL: expected exit 0 with a route, got $rc"; exit 1; fi
echo "PASS"
