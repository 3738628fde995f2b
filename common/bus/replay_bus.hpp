// Replay buses: where a replayed log goes (fieldline-camera --source log), so its messages never
// mix with a robot's live ones. Robot N's replay bus is port base_port + kReplayPortOffset + N on
// the same multicast group (defined with the other bus addresses in urls.cpp).
#pragma once

#include <string>

#include "common/bus/urls.hpp"

namespace fieldline::bus {

inline constexpr int kReplayPortOffset = 100;

// udpm URL of robot `robot_id`'s replay bus (1..99), e.g. udpm://239.255.76.67:7768?ttl=0&...
std::string replayBusUrl(int robot_id, const BusAddress& address = {});

}  // namespace fieldline::bus
