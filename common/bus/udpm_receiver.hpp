// The receiving side of an LCM udpm bus without LCM's receive thread: one UDP socket bound to the
// bus's group and port (as LCM binds it: SO_REUSEADDR, the group joined), read by the node's own
// event loop, with a socket filter that makes the kernel drop every datagram of a channel the
// process does not read (udpm_wire.hpp). LCM's udpm receive thread wakes for every datagram on
// the bus, copies it, looks its channel up and then wakes the main loop through a pipe; here a
// process that reads only MOTION_COMMAND wakes only for MOTION_COMMAND.
//
// Later fragments of a fragmented message name no channel. A process reading camera images takes
// all of them; a process reading a channel that only may span several datagrams (VISION_LINES,
// FIELD_FEATURES, CAMERA_PREVIEW: channels.hpp) takes them only from the senders (UDP source
// ports) it has seen publishing such a channel, and learns a new sender from its first message of
// one (the filter is then attached anew). Such a sender's first message is nearly always a single
// datagram; if it is a fragmented one, its later fragments may have been dropped before the
// sender was learnt: that message is refused and counted ("bus_incomplete"), its next ones arrive.
// Senders are known by port only, at most 8 (udpm::SenderPorts: the least recently seen forgotten
// first, one quiet for 10 s forgotten). A sender's unfinished message is given up and counted when
// it can no longer complete: at the sender's next short message (LCM sends one message at a time
// per sender), when the sender is forgotten, or when its first fragment is refused.
// So fusion and feature recognition no longer wake for the camera's image fragments.
//
// Datagrams are read in batches (recvmmsg): one system call per wake-up, not one per datagram
// plus the one that finds the socket empty.
//
// Publishing stays with LCM (lcm_publish): a publish-only lcm_t opens no receive socket and
// starts no thread (LCM 1.3.1 sets those up at the first subscribe or getFileno()).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <netinet/in.h>

#include "common/bus/udpm_wire.hpp"

namespace fieldline::bus {

struct UdpmAddress {
  in_addr group{};
  // Host byte order.
  std::uint16_t port = 0;
  // SO_RCVBUF to ask for; 0 keeps the system's default.
  int recv_buf_size = 0;
};

// The address of a udpm:// URL ("udpm://239.255.76.67:7668?ttl=0&recv_buf_size=4194304"; LCM's
// defaults for a missing group or port); nullopt for another provider. Throws
// std::invalid_argument for a udpm URL it cannot read.
std::optional<UdpmAddress> parseUdpmUrl(const std::string& url);

class UdpmReceiver {
 public:
  using MessageFn = std::function<void(std::string_view channel, const void* data, int size)>;
  // A problem with what arrived: kind ("bus_datagram", "bus_incomplete") and text.
  using ProblemFn = std::function<void(const char* kind, const std::string& text)>;

  explicit UdpmReceiver(UdpmAddress address);
  ~UdpmReceiver();
  UdpmReceiver(const UdpmReceiver&) = delete;
  UdpmReceiver& operator=(const UdpmReceiver&) = delete;

  // What this process reads on the bus; `everything` (a recorder, a bus monitor) takes every
  // datagram. The first call opens the socket; later calls replace the filter. Throws
  // std::system_error if the socket cannot be set up.
  void setChannels(const std::vector<std::string>& channels, bool everything);
  // The socket to wait on, or -1 while nothing is subscribed (publish-only: no socket at all).
  int fd() const { return fd_; }

  // Called after a batch of datagrams is read and before any of it is handled.
  using BatchFn = std::function<void()>;

  // Reads up to `max_datagrams` waiting datagrams without blocking and hands every complete
  // message of a channel it reads to `on_message`. Returns the number of messages handed on.
  // `now_us` is a monotonic time (Clock::monotonicNow): when the senders below were last seen.
  // `before_batch` (if given) runs after each read that returned datagrams, before they are
  // handled: bus::Node handles its deferred socket there, so that a deferred message that
  // arrived before one of the batch is handled before it.
  // Not re-entered: called again from inside its own on_message or before_batch (a handler of
  // any node sharing the connection that calls Node::handleDeferred or spins), it reads nothing
  // and returns 0. Reading there would reuse the buffers of the batch being handled and hand
  // newer messages on before the rest of that batch.
  int receive(int max_datagrams, std::int64_t now_us, const MessageFn& on_message,
              const ProblemFn& on_problem, const BatchFn* before_batch = nullptr);

  // Datagrams read from the socket since it was opened (what the process woke for).
  std::int64_t datagrams() const { return datagrams_; }
  // Read-system calls that returned datagrams (a batch each).
  std::int64_t batches() const { return batches_; }
  const udpm::FragmentAssembler& assembler() const { return assembler_; }
  // The senders (UDP source ports) whose later fragments the filter passes, when it does not
  // pass all of them.
  const std::vector<std::uint16_t>& fragmentSenders() const { return later_.from_ports; }

  // Datagrams read by one system call at most.
  static constexpr int kBatch = 8;
  // Senders of fragments remembered at most (the least recently seen is forgotten first; one not
  // seen for udpm::SenderPorts::kForget_us is forgotten).
  static constexpr std::size_t kMaxFragmentSenders = udpm::SenderPorts::kMax;

 private:
  void open();
  void attachFilter();
  // `d` (a short message or a first fragment that the filter passed) comes from `port`: learns
  // the port if the process takes later fragments only from known senders and `d`'s channel may
  // need them. Returns true if the port was new. If the filter cannot be attached anew, reports
  // it ("bus_datagram") and the port stays unknown.
  bool learnSender(const udpm::Datagram& d, std::uint16_t port, const ProblemFn& on_problem);
  // Forgets the senders not seen for long.
  void expireSenders(const ProblemFn& on_problem);
  // Gives up the unfinished messages of the senders in forgotten_.
  void forgetSenders(const ProblemFn& on_problem);
  // Attaches the filter for senders_; false (reported) if the kernel refused it.
  bool reattach(const ProblemFn& on_problem);
  void reportIncomplete(const ProblemFn& on_problem);
  // Handles one datagram of `size` bytes in `data` from `from`.
  int handle(const std::uint8_t* data, std::size_t size, const sockaddr_in& from,
             const MessageFn& on_message, const ProblemFn& on_problem);

  UdpmAddress address_;
  int fd_ = -1;
  bool everything_ = false;
  std::vector<std::string> channels_;
  // Learning the senders of later fragments (a channel of mayNeedSeveralDatagrams read, none of
  // usuallyNeedsSeveralDatagrams).
  bool learn_senders_ = false;
  udpm::LaterFragments later_;
  udpm::SenderPorts senders_;
  std::vector<std::uint16_t> forgotten_;
  // The time receive() was given.
  std::int64_t now_us_ = 0;
  // receive() is running (the guard against reading inside its own handlers).
  bool receiving_ = false;
  // kBatch buffers of kMaxDatagramBytes, allocated uninitialized (pages never written are never
  // touched).
  std::unique_ptr<std::uint8_t[]> buffers_;
  udpm::FragmentAssembler assembler_;
  std::int64_t datagrams_ = 0;
  std::int64_t batches_ = 0;
  std::int64_t reported_incomplete_ = 0;
};

}  // namespace fieldline::bus
