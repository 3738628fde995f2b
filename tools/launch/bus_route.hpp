// Which network interface a robot's bus leaves the machine through. LCM's udpm transport has no
// interface option: the kernel sends a multicast group out of the interface its route names (and
// joins it there to receive), so a robot watched from a laptop needs the bus group routed to its
// wireless interface, and `bus.interface` in the launch file says which one is meant
// (docs/launch.md, "Watching from a laptop").
#pragma once

#include <string>

#include "common/bus/urls.hpp"

namespace fieldline::launch {

struct RouteLookup {
  // The interface the group is routed to ("lo", "wlan0"); empty when there is no route.
  std::string interface;
  // Why there is none (or why it could not be found out).
  std::string error;
};

// The interface the kernel sends `group` out of (the source address it picks for it, and that
// address's interface).
RouteLookup multicastRoute(const std::string& group, int port);

// "" when the bus group is routed to `interface` (any route passes when `interface` is empty and
// a route exists), else the problem and its fix: "bus.interface wlan0: the kernel sends
// 239.255.76.67 through lo; route it: sudo ip route add 239.255.76.67/32 dev wlan0".
std::string checkBusRoute(const bus::BusAddress& address, const std::string& interface);

}  // namespace fieldline::launch
