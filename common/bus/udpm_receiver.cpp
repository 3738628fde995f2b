#include "common/bus/udpm_receiver.hpp"

#include <algorithm>
#include <array>
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
    : address_(address),
      buffers_(new std::uint8_t[static_cast<std::size_t>(kBatch) * udpm::kMaxDatagramBytes]) {}

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
    learn_senders_ = false;
    // No filter: every datagram, as LCM's receive thread gets them.
    // (The kernel wants an int-sized option here, although it reads none.)
    const int unused = 0;
    if (::setsockopt(fd_, SOL_SOCKET, SO_DETACH_FILTER, &unused, sizeof unused) < 0) {
      fail("SO_DETACH_FILTER");
    }
    return;
  }
  // Later fragments name no channel: a process reading camera images takes every one; a process
  // reading a channel that may span several datagrams takes those of the senders it has seen
  // publishing such a channel (learnSender); every other process never wakes for one.
  bool all = false, may = false;
  for (const std::string& c : channels) {
    all = all || usuallyNeedsSeveralDatagrams(c);
    may = may || mayNeedSeveralDatagrams(c);
  }
  later_.all = all;
  learn_senders_ = may && !all;
  if (!learn_senders_) senders_.clear();
  later_.from_ports = senders_.ports();
  attachFilter();
}

void UdpmReceiver::attachFilter() {
  const auto program = udpm::filterProgram(channels_, later_);
  sock_fprog prog{static_cast<unsigned short>(program.size()),
                  const_cast<sock_filter*>(program.data())};
  if (::setsockopt(fd_, SOL_SOCKET, SO_ATTACH_FILTER, &prog, sizeof prog) < 0) {
    fail("SO_ATTACH_FILTER");
  }
}

bool UdpmReceiver::learnSender(const udpm::Datagram& d, std::uint16_t port,
                               const ProblemFn& on_problem) {
  if (!learn_senders_ || !mayNeedSeveralDatagrams(d.channel)) return false;
  if (senders_.refresh(port, now_us_)) return false;
  const udpm::SenderPorts before = senders_;
  forgotten_.clear();
  senders_.add(port, now_us_, forgotten_);
  if (!reattach(on_problem)) {
    // The kernel keeps the filter it had: so do we (and the port stays unknown).
    senders_ = before;
    later_.from_ports = senders_.ports();
    return true;
  }
  forgetSenders(on_problem);
  return true;
}

void UdpmReceiver::expireSenders(const ProblemFn& on_problem) {
  // Every receive(): nothing copied unless a port goes.
  if (!learn_senders_ || !senders_.anyQuiet(now_us_)) return;
  const udpm::SenderPorts before = senders_;
  forgotten_.clear();
  senders_.expire(now_us_, forgotten_);
  if (forgotten_.empty()) return;
  if (!reattach(on_problem)) {
    senders_ = before;
    later_.from_ports = senders_.ports();
    return;
  }
  forgetSenders(on_problem);
}

void UdpmReceiver::forgetSenders(const ProblemFn& on_problem) {
  // Their later fragments no longer pass: what they had half sent never completes.
  for (const std::uint16_t port : forgotten_)
    assembler_.giveUpPort(port);
  reportIncomplete(on_problem);
}

bool UdpmReceiver::reattach(const ProblemFn& on_problem) {
  later_.from_ports = senders_.ports();
  try {
    attachFilter();
    return true;
  } catch (const std::system_error& e) {
    on_problem(
        "bus_datagram",
        fmt::format("re-attaching the socket filter for the senders of fragments: {}", e.what()));
    return false;
  }
}

void UdpmReceiver::reportIncomplete(const ProblemFn& on_problem) {
  if (assembler_.incomplete() <= reported_incomplete_) return;
  on_problem("bus_incomplete",
             fmt::format("{}: a message lost fragments ({} so far)",
                         assembler_.lastIncompleteChannel(), assembler_.incomplete()));
  reported_incomplete_ = assembler_.incomplete();
}

int UdpmReceiver::handle(const std::uint8_t* data, std::size_t size, const sockaddr_in& from,
                         const MessageFn& on_message, const ProblemFn& on_problem) {
  ++datagrams_;
  udpm::Datagram d;
  if (const char* error = udpm::parseDatagram(std::span<const std::uint8_t>(data, size), d)) {
    on_problem("bus_datagram", fmt::format("{}-byte datagram from {}:{}: {}", size,
                                           inet_ntoa(from.sin_addr), ntohs(from.sin_port), error));
    return 0;
  }
  const std::uint16_t port = ntohs(from.sin_port);
  const std::uint64_t sender = (std::uint64_t{ntohl(from.sin_addr.s_addr)} << 16) | port;
  // Every datagram of a known sender keeps it known (the least recently seen is forgotten).
  if (learn_senders_) senders_.refresh(port, now_us_);
  if (!d.fragment) {
    // LCM sends one message at a time per sender: its unfinished one lost fragments.
    assembler_.giveUp(sender);
    reportIncomplete(on_problem);
    learnSender(d, port, on_problem);
    // The filter passed it, but a recorder takes every channel: the handlers choose.
    on_message(d.channel, d.bytes.data(), static_cast<int>(d.bytes.size()));
    return 1;
  }
  if (d.fragment_no == 0 && learnSender(d, port, on_problem)) {
    // The filter did not pass this sender's later fragments until now: some of this message's
    // may be gone. Refused and counted, never handed on half; the sender's next ones arrive
    // whole. (Later fragments of it that still arrive find no first fragment: no second count.)
    // What the sender had left unfinished is given up too.
    assembler_.giveUp(sender);
    reportIncomplete(on_problem);
    on_problem(
        "bus_incomplete",
        fmt::format("{}: a {}-byte message in {} datagrams from a sender not seen before "
                    "({}:{}): refused, its later fragments were not taken; they are now",
                    d.channel, d.message_size, d.fragment_count, inet_ntoa(from.sin_addr), port));
    return 0;
  }
  udpm::FragmentAssembler::Message message;
  const auto outcome = assembler_.add(sender, d, message);
  reportIncomplete(on_problem);
  if (outcome != udpm::FragmentAssembler::Outcome::kComplete) return 0;
  on_message(message.channel, message.bytes.data(), static_cast<int>(message.bytes.size()));
  return 1;
}

int UdpmReceiver::receive(int max_datagrams, std::int64_t now_us, const MessageFn& on_message,
                          const ProblemFn& on_problem, const BatchFn* before_batch) {
  if (fd_ < 0 || receiving_) return 0;
  receiving_ = true;
  struct Done {
    bool& flag;
    ~Done() { flag = false; }
  } const done{receiving_};
  now_us_ = now_us;
  expireSenders(on_problem);
  std::array<mmsghdr, kBatch> headers{};
  std::array<iovec, kBatch> vectors{};
  std::array<sockaddr_in, kBatch> senders{};
  int handed_on = 0;
  for (int read = 0; read < max_datagrams;) {
    const int want = std::min(kBatch, max_datagrams - read);
    for (int i = 0; i < want; ++i) {
      vectors[i] = iovec{buffers_.get() + static_cast<std::size_t>(i) * udpm::kMaxDatagramBytes,
                         udpm::kMaxDatagramBytes};
      headers[i] = mmsghdr{};
      headers[i].msg_hdr.msg_name = &senders[i];
      headers[i].msg_hdr.msg_namelen = sizeof senders[i];
      headers[i].msg_hdr.msg_iov = &vectors[i];
      headers[i].msg_hdr.msg_iovlen = 1;
    }
    const int got =
        ::recvmmsg(fd_, headers.data(), static_cast<unsigned>(want), MSG_DONTWAIT, nullptr);
    if (got <= 0) {
      if (got < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) {
        on_problem("bus_datagram", std::string("reading the bus socket: ") + std::strerror(errno));
      }
      break;
    }
    ++batches_;
    read += got;
    if (before_batch) (*before_batch)();
    for (int i = 0; i < got; ++i) {
      handed_on += handle(static_cast<const std::uint8_t*>(vectors[i].iov_base), headers[i].msg_len,
                          senders[i], on_message, on_problem);
    }
    // Fewer than asked for: the socket was empty (what arrives since wakes the next poll).
    if (got < want) break;
  }
  return handed_on;
}

}  // namespace fieldline::bus
