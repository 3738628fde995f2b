// Moving team packets: an abstract datagram link (so the node is tested in one process over an
// in-memory hub) and its UDP implementation on Boost.Asio: multicast to a team group by default,
// or a list of unicast peers (access points often handle multicast badly), optionally bound to
// one network interface.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "common/time/clock.hpp"

namespace fieldline::teamcomm {

class TransportError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class PacketLink {
 public:
  virtual ~PacketLink() = default;
  // Sends one datagram to the team; false when the system refused it (counted by the caller).
  virtual bool send(std::span<const std::uint8_t> bytes) = 0;
  // Hands over every datagram that has arrived, without waiting. `age_us` is how long ago the
  // system received it (0 when unknown), so the caller can stamp the true arrival time.
  virtual void poll(
      const std::function<void(std::span<const std::uint8_t> bytes, Utime age_us)>& on_packet) = 0;
  // The descriptor to wait on for arrivals (-1 when there is none).
  virtual int fileDescriptor() const { return -1; }
  // Datagrams the system dropped before we could read them (a full receive buffer: a flood, or
  // a node too slow), since the link was opened; -1 when the link cannot tell.
  virtual std::int64_t kernelDrops() const { return -1; }
};

struct UdpOptions {
  // Multicast group the team shares; empty: unicast to `peers` only.
  std::string group = "239.255.76.100";
  std::uint16_t port = 47600;
  // "host:port" of every teammate (or of an access point that relays), used instead of the group.
  std::vector<std::string> peers;
  // Network interface name to bind to and to send multicast from; empty: the system's choice.
  std::string interface;
  // Multicast hops: 1 keeps the team's traffic on its own network.
  int ttl = 1;
  // Deliver our own multicast back to this host: needed when several robots share one machine
  // (the simulated team); each node ignores its own packets by robot id.
  bool loopback = true;
};

// Opens the socket (SO_REUSEADDR, so several robots on one machine share the port); throws
// TransportError naming what failed and what to check.
std::unique_ptr<PacketLink> openUdpLink(const UdpOptions& options);

// Parses "host:port" (IPv4 dotted quad or a resolvable name); throws TransportError.
std::pair<std::string, std::uint16_t> parsePeer(const std::string& text);

}  // namespace fieldline::teamcomm
