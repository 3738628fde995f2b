#include "common/bus/udpm_receiver.hpp"

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <system_error>

#include <arpa/inet.h>
#include <fmt/format.h>
#include <sys/socket.h>
#include <unistd.h>

#include "common/bus/channels.hpp"

namespace fieldline::bus {
namespace {

[[noreturn]] void fail(const std::string& what) {
  throw std::system_error(errno, std::generic_category(), what);
}

}  // namespace

std::optional<UdpmAddress> parseUdpmUrl(const std::string& url) {
  constexpr std::string_view kScheme = "udpm://";
  if (url.rfind(kScheme, 0) != 0) return std::nullopt;
  const std::size_t query = url.find('?');
  std::string network = url.substr(
      kScheme.size(), query == std::string::npos ? std::string::npos : query - kScheme.size());
  // LCM's defaults.
  if (network.empty()) network = "239.255.76.67:7667";
  UdpmAddress a;
  const std::size_t colon = network.find(':');
  const std::string group = network.substr(0, colon);
  if (inet_aton(group.c_str(), &a.group) == 0) {
    throw std::invalid_argument("bus URL '" + url + "': '" + group + "' is no IPv4 address");
  }
  a.port = 7667;
  if (colon != std::string::npos) {
    const std::string port = network.substr(colon + 1);
    std::size_t used = 0;
    int value = -1;
    try {
      value = std::stoi(port, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != port.size() || value < 0 || value > 65535) {
      throw std::invalid_argument("bus URL '" + url + "': port '" + port + "' is not 0..65535");
    }
    a.port = static_cast<std::uint16_t>(value);
  }
  if (query != std::string::npos) {
    std::size_t from = query + 1;
    while (from < url.size()) {
      std::size_t end = url.find('&', from);
      if (end == std::string::npos) end = url.size();
      const std::string pair = url.substr(from, end - from);
      constexpr std::string_view kRecv = "recv_buf_size=";
      if (pair.rfind(kRecv, 0) == 0) {
        try {
          a.recv_buf_size = std::stoi(pair.substr(kRecv.size()));
        } catch (const std::exception&) {
          throw std::invalid_argument("bus URL '" + url + "': bad recv_buf_size");
        }
      }
      from = end + 1;
    }
  }
  return a;
}

UdpmReceiver::UdpmReceiver(UdpmAddress address)
    : address_(address), buffer_(udpm::kMaxDatagramBytes) {}

UdpmReceiver::~UdpmReceiver() {
  if (fd_ >= 0) ::close(fd_);
}

void UdpmReceiver::open() {
  fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd_ < 0) fail("bus receive socket");
  const int on = 1;
  // Every process of the robot binds the same group and port (as LCM does).
  if (::setsockopt(fd_, SOL_SOCKET, SO_REUSEADDR, &on, sizeof on) < 0) fail("SO_REUSEADDR");
  if (address_.recv_buf_size > 0) {
    // Capped by net.core.rmem_max; the kernel doubles what it grants.
    (void)::setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &address_.recv_buf_size,
                       sizeof address_.recv_buf_size);
  }
  // No SO_RXQ_OVFL: the kernel counts a datagram the filter refuses as a drop of the socket
  // (sk_drops), so the count would mostly be the channels this process does not read. A message
  // lost to a full buffer shows as a seq gap (DROPS) of its channel in SERVICE_STATUS.
  // Drop everything until the filter of the first subscription is in place below.
  const auto drop_all = udpm::filterProgram({}, false);
  sock_fprog prog{static_cast<unsigned short>(drop_all.size()),
                  const_cast<sock_filter*>(drop_all.data())};
  if (::setsockopt(fd_, SOL_SOCKET, SO_ATTACH_FILTER, &prog, sizeof prog) < 0) {
    fail("SO_ATTACH_FILTER");
  }
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr = address_.group;
  addr.sin_port = htons(address_.port);
  if (::bind(fd_, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) < 0) {
    fail(fmt::format("bind {}:{}", inet_ntoa(address_.group), address_.port));
  }
  ip_mreq mreq{};
  mreq.imr_multiaddr = address_.group;
  mreq.imr_interface.s_addr = htonl(INADDR_ANY);
  if (::setsockopt(fd_, IPPROTO_IP, IP_ADD_MEMBERSHIP, &mreq, sizeof mreq) < 0) {
    fail(fmt::format("joining the multicast group {}", inet_ntoa(address_.group)));
  }
}

void UdpmReceiver::setChannels(const std::vector<std::string>& channels, bool everything) {
  if (fd_ < 0) open();
  channels_ = channels;
  everything_ = everything;
  if (everything) {
    // No filter: every datagram, as LCM's receive thread gets them.
    // (The kernel wants an int-sized option here, although it reads none.)
    const int unused = 0;
    if (::setsockopt(fd_, SOL_SOCKET, SO_DETACH_FILTER, &unused, sizeof unused) < 0) {
      fail("SO_DETACH_FILTER");
    }
    return;
  }
  // Later fragments name no channel: a process reading a channel whose messages may span
  // several datagrams takes the later fragments of every channel (and drops the strangers'
  // after reading them); every other process never wakes for one.
  bool big = false;
  for (const std::string& c : channels)
    big = big || mayNeedSeveralDatagrams(c);
  const auto program = udpm::filterProgram(channels, big);
  sock_fprog prog{static_cast<unsigned short>(program.size()),
                  const_cast<sock_filter*>(program.data())};
  if (::setsockopt(fd_, SOL_SOCKET, SO_ATTACH_FILTER, &prog, sizeof prog) < 0) {
    fail("SO_ATTACH_FILTER");
  }
}

int UdpmReceiver::receive(int max_datagrams, const MessageFn& on_message,
                          const ProblemFn& on_problem) {
  if (fd_ < 0) return 0;
  int handed_on = 0;
  for (int n = 0; n < max_datagrams; ++n) {
    iovec vec{buffer_.data(), buffer_.size()};
    sockaddr_in from{};
    msghdr msg{};
    msg.msg_name = &from;
    msg.msg_namelen = sizeof from;
    msg.msg_iov = &vec;
    msg.msg_iovlen = 1;
    const ssize_t size = ::recvmsg(fd_, &msg, MSG_DONTWAIT);
    if (size < 0) {
      if (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) {
        on_problem("bus_datagram", std::string("reading the bus socket: ") + std::strerror(errno));
      }
      break;
    }
    ++datagrams_;
    udpm::Datagram d;
    const std::span<const std::uint8_t> bytes(buffer_.data(), static_cast<std::size_t>(size));
    if (const char* error = udpm::parseDatagram(bytes, d)) {
      on_problem("bus_datagram",
                 fmt::format("{}-byte datagram from {}:{}: {}", size, inet_ntoa(from.sin_addr),
                             ntohs(from.sin_port), error));
      continue;
    }
    if (!d.fragment) {
      // The filter passed it, but a recorder takes every channel: the handlers choose.
      on_message(d.channel, d.bytes.data(), static_cast<int>(d.bytes.size()));
      ++handed_on;
      continue;
    }
    const std::uint64_t sender =
        (std::uint64_t{ntohl(from.sin_addr.s_addr)} << 16) | ntohs(from.sin_port);
    udpm::FragmentAssembler::Message message;
    const auto outcome = assembler_.add(sender, d, message);
    if (assembler_.incomplete() > reported_incomplete_) {
      on_problem("bus_incomplete",
                 fmt::format("{}: a message lost fragments ({} so far)",
                             assembler_.lastIncompleteChannel(), assembler_.incomplete()));
      reported_incomplete_ = assembler_.incomplete();
    }
    if (outcome == udpm::FragmentAssembler::Outcome::kComplete) {
      on_message(message.channel, message.bytes.data(), static_cast<int>(message.bytes.size()));
      ++handed_on;
    }
  }
  return handed_on;
}

}  // namespace fieldline::bus
