#include "teamcomm/transport.hpp"

#include <ifaddrs.h>
#include <net/if.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>

#include <array>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/multicast.hpp>
#include <boost/asio/ip/udp.hpp>
#include <cerrno>
#include <cstring>
#include <ctime>
#include <optional>

namespace fieldline::teamcomm {
namespace {

namespace asio = boost::asio;
using asio::ip::udp;

// The IPv4 address of a named interface.
asio::ip::address_v4 interfaceAddress(const std::string& name) {
  ifaddrs* list = nullptr;
  if (::getifaddrs(&list) != 0)
    throw TransportError("getifaddrs failed: " + std::string(std::strerror(errno)));
  std::optional<asio::ip::address_v4> found;
  for (ifaddrs* it = list; it; it = it->ifa_next) {
    if (it->ifa_addr && it->ifa_addr->sa_family == AF_INET && name == it->ifa_name) {
      const auto* in = reinterpret_cast<const sockaddr_in*>(it->ifa_addr);
      found = asio::ip::address_v4(ntohl(in->sin_addr.s_addr));
      break;
    }
  }
  ::freeifaddrs(list);
  if (!found) throw TransportError("interface " + name + " has no IPv4 address (see `ip addr`)");
  return *found;
}

Utime systemNowUs() {
  timespec ts{};
  ::clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<Utime>(ts.tv_sec) * kMicrosPerSecond + ts.tv_nsec / 1000;
}

class UdpLink final : public PacketLink {
 public:
  explicit UdpLink(const UdpOptions& o) : socket_(io_) {
    boost::system::error_code ec;
    auto check = [&](const char* what) {
      if (ec) throw TransportError(std::string("team UDP: ") + what + ": " + ec.message());
    };
    socket_.open(udp::v4(), ec);
    check("open");
    socket_.set_option(asio::socket_base::reuse_address(true), ec);
    check("SO_REUSEADDR");
    const int fd = socket_.native_handle();
    if (!o.interface.empty() && ::setsockopt(fd, SOL_SOCKET, SO_BINDTODEVICE, o.interface.c_str(),
                                             static_cast<socklen_t>(o.interface.size())) != 0) {
      throw TransportError("team UDP: cannot bind to interface " + o.interface + ": " +
                           std::strerror(errno));
    }
    // Kernel receive stamps, so arrival times do not depend on when we get round to reading.
    const int on = 1;
    // Without them (never seen on Linux) the age is 0 and arrival is stamped when read.
    (void)::setsockopt(fd, SOL_SOCKET, SO_TIMESTAMPNS, &on, sizeof on);
    // The kernel's count of datagrams dropped for a full receive buffer comes with every datagram
    // read (SO_RXQ_OVFL), so a flood shows in the status instead of only in /proc/net/snmp.
    (void)::setsockopt(fd, SOL_SOCKET, SO_RXQ_OVFL, &on, sizeof on);
    // Only the groups this socket joined: with the default (IP_MULTICAST_ALL on) a socket bound
    // to the port also hears any other group joined on this host at that port, e.g. an LCM bus
    // put on the team port by mistake.
    const int off = 0;
    (void)::setsockopt(fd, IPPROTO_IP, IP_MULTICAST_ALL, &off, sizeof off);
    // Room for a burst (or a flood) while the node is busy; capped by net.core.rmem_max.
    socket_.set_option(asio::socket_base::receive_buffer_size(1 << 20), ec);
    socket_.bind(udp::endpoint(udp::v4(), o.port), ec);
    check(("bind to port " + std::to_string(o.port)).c_str());
    if (!o.group.empty()) {
      const auto group = asio::ip::make_address_v4(o.group, ec);
      check(("multicast group " + o.group).c_str());
      if (!group.is_multicast())
        throw TransportError("team UDP: " + o.group + " is not a multicast group");
      if (o.interface.empty()) {
        socket_.set_option(asio::ip::multicast::join_group(group), ec);
      } else {
        const auto local = interfaceAddress(o.interface);
        socket_.set_option(asio::ip::multicast::join_group(group, local), ec);
        if (!ec) socket_.set_option(asio::ip::multicast::outbound_interface(local), ec);
      }
      if (ec) {
        throw TransportError("team UDP: cannot join " + o.group + ": " + ec.message() +
                             " (is there a multicast route? `ip route add 224.0.0.0/4 dev lo` on "
                             "one machine, or name the WiFi interface)");
      }
      socket_.set_option(asio::ip::multicast::hops(o.ttl), ec);
      check("multicast TTL");
      socket_.set_option(asio::ip::multicast::enable_loopback(o.loopback), ec);
      check("multicast loopback");
      destinations_.emplace_back(group, o.port);
    }
    for (const std::string& peer : o.peers) {
      const auto [host, port] = parsePeer(peer);
      udp::resolver resolver(io_);
      const auto results = resolver.resolve(udp::v4(), host, std::to_string(port), ec);
      if (ec || results.empty()) throw TransportError("team UDP: cannot resolve peer " + peer);
      destinations_.push_back(results.begin()->endpoint());
    }
    if (destinations_.empty())
      throw TransportError("team UDP: neither a group nor peers to send to");
    socket_.non_blocking(true, ec);
    check("non-blocking");
  }

  bool send(std::span<const std::uint8_t> bytes) override {
    bool all = true;
    for (const auto& to : destinations_) {
      boost::system::error_code ec;
      socket_.send_to(asio::buffer(bytes.data(), bytes.size()), to, 0, ec);
      all = all && !ec;
    }
    return all;
  }

  void poll(const std::function<void(std::span<const std::uint8_t>, Utime)>& on_packet) override {
    // Bounded, so a flood cannot keep the node from its timers.
    for (int n = 0; n < 256; ++n) {
      iovec iov{buffer_.data(), buffer_.size()};
      std::array<char, CMSG_SPACE(sizeof(timespec)) + CMSG_SPACE(sizeof(std::uint32_t))> control{};
      msghdr msg{};
      msg.msg_iov = &iov;
      msg.msg_iovlen = 1;
      msg.msg_control = control.data();
      msg.msg_controllen = control.size();
      const ssize_t got = ::recvmsg(socket_.native_handle(), &msg, MSG_DONTWAIT);
      if (got < 0) return;  // EAGAIN: nothing more; other errors: try again next poll
      Utime age = 0;
      for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c; c = CMSG_NXTHDR(&msg, c)) {
        if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMPNS) {
          timespec ts{};
          std::memcpy(&ts, CMSG_DATA(c), sizeof ts);
          const Utime stamp = static_cast<Utime>(ts.tv_sec) * kMicrosPerSecond + ts.tv_nsec / 1000;
          age = std::max<Utime>(0, systemNowUs() - stamp);
        } else if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SO_RXQ_OVFL) {
          std::uint32_t dropped = 0;
          std::memcpy(&dropped, CMSG_DATA(c), sizeof dropped);
          // The kernel's counter is 32 bits and wraps; keep a 64-bit total.
          kernel_drops_ += static_cast<std::uint32_t>(dropped - last_drop_counter_);
          last_drop_counter_ = dropped;
        }
      }
      // A datagram larger than the buffer is truncated by the kernel: hand over one byte more than
      // the largest valid packet so the decoder refuses it as oversized.
      const std::size_t size =
          (msg.msg_flags & MSG_TRUNC) ? buffer_.size() : static_cast<std::size_t>(got);
      on_packet(std::span<const std::uint8_t>(buffer_.data(), size), age);
    }
  }

  int fileDescriptor() const override { return const_cast<udp::socket&>(socket_).native_handle(); }
  std::int64_t kernelDrops() const override { return kernel_drops_; }

 private:
  asio::io_context io_;
  udp::socket socket_;
  std::vector<udp::endpoint> destinations_;
  // One byte beyond the protocol's 1,400-byte limit, so oversize is detectable.
  std::array<std::uint8_t, 1401> buffer_{};
  std::uint32_t last_drop_counter_ = 0;
  std::int64_t kernel_drops_ = 0;
};

}  // namespace

std::pair<std::string, std::uint16_t> parsePeer(const std::string& text) {
  const auto colon = text.rfind(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == text.size()) {
    throw TransportError("peer '" + text + "' is not host:port");
  }
  const std::string port_text = text.substr(colon + 1);
  int port = 0;
  for (char c : port_text) {
    if (c < '0' || c > '9' || port > 65535) throw TransportError("peer '" + text + "': bad port");
    port = port * 10 + (c - '0');
  }
  if (port < 1 || port > 65535) throw TransportError("peer '" + text + "': port out of 1..65535");
  return {text.substr(0, colon), static_cast<std::uint16_t>(port)};
}

std::unique_ptr<PacketLink> openUdpLink(const UdpOptions& options) {
  return std::make_unique<UdpLink>(options);
}

}  // namespace fieldline::teamcomm
