#include "common/bus/urls.hpp"

#include <stdexcept>

#include <fmt/format.h>

#include "common/bus/replay_bus.hpp"

namespace fieldline::bus {
namespace {
std::string udpmUrl(const BusAddress& a, int port) {
  return fmt::format("udpm://{}:{}?ttl={}&recv_buf_size={}", a.group, port, a.ttl, a.recv_buf_size);
}
}  // namespace

std::string robotBusUrl(int robot_id, const BusAddress& address) {
  if (robot_id < 1 || robot_id > 99) {
    throw std::invalid_argument(fmt::format("robot id {} out of range 1..99", robot_id));
  }
  return udpmUrl(address, address.base_port + robot_id);
}

std::string simBusUrl(const BusAddress& address) {
  return udpmUrl(address, address.base_port);
}

std::string replayBusUrl(int robot_id, const BusAddress& address) {
  if (robot_id < 1 || robot_id > 99) {
    throw std::invalid_argument(fmt::format("robot id {} out of range 1..99", robot_id));
  }
  return udpmUrl(address, address.base_port + kReplayPortOffset + robot_id);
}

}  // namespace fieldline::bus
