#include "common/bus/urls.hpp"

#include <algorithm>
#include <stdexcept>

#include <fmt/format.h>

#include "common/bus/channels.hpp"
#include "common/bus/frames_bus.hpp"
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

std::string localOnlyUrl(const std::string& url) {
  if (url.rfind("udpm://", 0) != 0) return url;
  const std::size_t query = url.find('?');
  if (query == std::string::npos) return url + "?ttl=0";
  // Options are key=value pairs joined by '&': replace the ttl pair, or add one.
  std::string out = url.substr(0, query + 1);
  bool had_ttl = false;
  std::size_t from = query + 1;
  while (from <= url.size()) {
    std::size_t end = url.find('&', from);
    if (end == std::string::npos) end = url.size();
    std::string pair = url.substr(from, end - from);
    if (pair.rfind("ttl=", 0) == 0) {
      pair = "ttl=0";
      had_ttl = true;
    }
    if (!pair.empty()) out += (out.back() == '?' ? "" : "&") + pair;
    from = end + 1;
  }
  if (!had_ttl) out += (out.back() == '?' ? "" : "&") + std::string("ttl=0");
  return out;
}

bool travelsOnFramesBus(std::string_view channel) {
  return channel == channels::kCameraImage.name;
}

std::string framesBusUrl(const std::string& url) {
  constexpr std::string_view kScheme = "udpm://";
  if (url.rfind(kScheme, 0) != 0) return url;
  const std::size_t query = std::min(url.find('?'), url.size());
  const std::string address = url.substr(kScheme.size(), query - kScheme.size());
  const std::size_t colon = address.rfind(':');
  // LCM's default port when the URL names none.
  int port = 7667;
  std::string host = address;
  if (colon != std::string::npos) {
    host = address.substr(0, colon);
    try {
      std::size_t used = 0;
      port = std::stoi(address.substr(colon + 1), &used);
      if (used != address.size() - colon - 1) return url;
    } catch (const std::exception&) {
      return url;  // not a URL this knows how to move: frames stay on it (LCM reports it)
    }
  }
  if (port <= 0 || port + kFramesPortOffset > 65535) return url;
  return fmt::format("{}{}:{}{}", kScheme, host, port + kFramesPortOffset, url.substr(query));
}

std::string replayBusUrl(int robot_id, const BusAddress& address) {
  if (robot_id < 1 || robot_id > 99) {
    throw std::invalid_argument(fmt::format("robot id {} out of range 1..99", robot_id));
  }
  return udpmUrl(address, address.base_port + kReplayPortOffset + robot_id);
}

}  // namespace fieldline::bus
