// Bus addresses: one LCM bus per robot, one for the simulator (ARCHITECTURE.md, "Processes and
// buses").
#pragma once

#include <string>

namespace fieldline::bus {

struct BusAddress {
  // Multicast group shared by all buses; they differ by port.
  std::string group = "239.255.76.67";
  // The simulator's port; robot N listens on base_port + N.
  int base_port = 7667;
  // 0 keeps traffic on this machine.
  int ttl = 0;
  // Socket receive buffer, bytes: large enough for bursts of camera frames (capped by
  // net.core.rmem_max).
  int recv_buf_size = 4 * 1024 * 1024;
};

// udpm URL of robot `robot_id` (1..6), e.g. udpm://239.255.76.67:7668?ttl=0&recv_buf_size=4194304.
std::string robotBusUrl(int robot_id, const BusAddress& address = {});
// udpm URL of the simulator's bus (port base_port).
std::string simBusUrl(const BusAddress& address = {});

// The same udpm bus with ttl=0: what is published through it stays on this machine while the
// bus's other traffic may leave it (the camera's full frames on a watched bus). Other URLs
// (memq://, a udpm URL already at ttl=0) come back unchanged.
std::string localOnlyUrl(const std::string& url);

}  // namespace fieldline::bus
