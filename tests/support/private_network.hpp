#pragma once
// A test that runs LCM over real multicast sockets moves its own process into a private network
// namespace first, so runs never hear each other (every case runs in a process of its own).

#include <sched.h>

#include <cstdlib>

namespace fieldline::test {

// Enters a new network namespace and gives its loopback the multicast route LCM needs. False
// when that is not allowed here (needs root, as scripts/test runs, or user namespaces).
inline bool enterPrivateMulticastNetwork() {
  return ::unshare(CLONE_NEWNET) == 0 && std::system(
                                             "ip link set lo up && ip link set lo multicast on && "
                                             "ip route add 224.0.0.0/4 dev lo") == 0;
}

}  // namespace fieldline::test
