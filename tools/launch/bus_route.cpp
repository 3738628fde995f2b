#include "tools/launch/bus_route.hpp"

#include <cerrno>
#include <cstring>

#include <arpa/inet.h>
#include <ifaddrs.h>
#include <net/if.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <fmt/format.h>

namespace fieldline::launch {

RouteLookup multicastRoute(const std::string& group, int port) {
  RouteLookup out;
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(static_cast<std::uint16_t>(port));
  if (::inet_pton(AF_INET, group.c_str(), &to.sin_addr) != 1) {
    out.error = "'" + group + "' is not an IPv4 address";
    return out;
  }
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    out.error = std::string("socket: ") + std::strerror(errno);
    return out;
  }
  // A datagram socket's connect() only looks up the route; nothing is sent.
  sockaddr_in from{};
  socklen_t length = sizeof from;
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&to), sizeof to) != 0) {
    out.error = fmt::format("no route for {} ({})", group, std::strerror(errno));
  } else if (::getsockname(fd, reinterpret_cast<sockaddr*>(&from), &length) != 0) {
    out.error = std::string("getsockname: ") + std::strerror(errno);
  }
  ::close(fd);
  if (!out.error.empty()) return out;
  ifaddrs* list = nullptr;
  if (::getifaddrs(&list) != 0) {
    out.error = std::string("getifaddrs: ") + std::strerror(errno);
    return out;
  }
  for (const ifaddrs* a = list; a != nullptr; a = a->ifa_next) {
    if (a->ifa_addr == nullptr || a->ifa_addr->sa_family != AF_INET) continue;
    const auto* in = reinterpret_cast<const sockaddr_in*>(a->ifa_addr);
    if (in->sin_addr.s_addr == from.sin_addr.s_addr) {
      out.interface = a->ifa_name;
      break;
    }
  }
  ::freeifaddrs(list);
  if (out.interface.empty()) {
    char text[INET_ADDRSTRLEN] = {};
    ::inet_ntop(AF_INET, &from.sin_addr, text, sizeof text);
    out.error = fmt::format("the route for {} uses {}, which no interface has", group, text);
  }
  return out;
}

std::string checkBusRoute(const bus::BusAddress& address, const std::string& interface) {
  if (!interface.empty() && ::if_nametoindex(interface.c_str()) == 0) {
    return fmt::format("bus.interface {}: no such network interface; list them with ip link",
                       interface);
  }
  const RouteLookup route = multicastRoute(address.group, address.base_port);
  if (route.interface.empty()) {
    return fmt::format(
        "the bus group {}: {}; LCM needs a multicast route: sudo ip route add "
        "224.0.0.0/4 dev {}",
        address.group, route.error, interface.empty() ? "lo" : interface);
  }
  if (!interface.empty() && route.interface != interface) {
    return fmt::format(
        "bus.interface {}: the kernel sends the bus group {} through {}; route it to {}: sudo ip "
        "route add {}/32 dev {} (or correct bus.interface)",
        interface, address.group, route.interface, interface, address.group, interface);
  }
  return "";
}

}  // namespace fieldline::launch
