// LCM's udpm wire format (LCM 1.3.1, unchanged since LCM 1.0), read without LCM: bus::Node
// receives its robot's bus on a socket of its own (udpm_receiver.hpp) and publishes through LCM,
// so lcm-spy, lcm-logger and every other LCM program keep seeing the same datagrams.
//
// A datagram is either a whole message or one fragment of a big one; all integers big-endian:
//   short:    u32 magic "LC02", u32 seqno, channel '\0', payload
//   fragment: u32 magic "LC03", u32 seqno, u32 message size, u32 offset of this fragment's bytes,
//             u16 fragment number, u16 fragment count; fragment 0 then carries channel '\0'
//             before its bytes, the others only bytes.
// A sender numbers its messages with one seqno; fragments of a message share it.
//
// The socket filter (filterProgram) lets the kernel drop what a process does not read, so the
// process does not wake for it: a short message or a first fragment whose channel is not one of
// the process's, and every later fragment (they carry no channel name) except those the process
// may need: all of them for a process that reads camera images, otherwise only those from the
// senders (UDP source ports) seen publishing a channel the process reads that may span several
// datagrams (udpm_receiver.hpp).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <linux/filter.h>

namespace fieldline::bus::udpm {

inline constexpr std::uint32_t kMagicShort = 0x4c433032;     // "LC02"
inline constexpr std::uint32_t kMagicFragment = 0x4c433033;  // "LC03"
inline constexpr std::size_t kShortHeaderBytes = 8;
inline constexpr std::size_t kFragmentHeaderBytes = 20;
// LCM refuses longer channel names.
inline constexpr std::size_t kMaxChannelLength = 63;
// LCM's limit on a reassembled message.
inline constexpr std::uint32_t kMaxMessageBytes = 1u << 28;
// The largest UDP payload.
inline constexpr std::size_t kMaxDatagramBytes = 65535;

struct Datagram {
  bool fragment = false;
  std::uint32_t seqno = 0;
  // Empty for a fragment other than the first.
  std::string_view channel;
  // The message's bytes in this datagram (all of them for a short message).
  std::span<const std::uint8_t> bytes;
  // Fragments only.
  std::uint32_t message_size = 0;
  std::uint32_t offset = 0;
  std::uint16_t fragment_no = 0;
  std::uint16_t fragment_count = 0;
};

// Parses one datagram into `out` (views into `bytes`). Returns nullptr when it is well formed,
// otherwise a static text saying what is wrong (and `out` is unspecified).
const char* parseDatagram(std::span<const std::uint8_t> bytes, Datagram& out);

// Reassembles fragmented messages, one in flight per sender (LCM sends a message's fragments in
// order, one message at a time). Buffers are reused: no allocation once they have grown to the
// largest message.
class FragmentAssembler {
 public:
  struct Message {
    std::string_view channel;
    std::span<const std::uint8_t> bytes;
  };
  enum class Outcome {
    // Stored; the message is not complete yet.
    kPending,
    // `message` is complete (valid until the next add()).
    kComplete,
    // The fragment does not fit its message (offset or size beyond it, number out of range).
    kInvalid,
  };

  // Adds fragment `d` from `sender` (source address and port). A fragment of a newer message
  // from a sender abandons its unfinished one: counted in incomplete() if its first fragment
  // (and so its channel) had arrived, otherwise it was a message the filter kept from us.
  Outcome add(std::uint64_t sender, const Datagram& d, Message& message);

  // Gives up the unfinished message of `sender`, or of every sender with UDP source port `port`
  // (counted as add() counts an abandoned one). LCM sends one message at a time per sender, so a
  // short message from a sender means its unfinished one lost fragments; a sender whose later
  // fragments the socket filter no longer passes never finishes one either.
  void giveUp(std::uint64_t sender);
  void giveUpPort(std::uint16_t port);

  // Messages given up with fragments missing, and the channel of the last one.
  std::int64_t incomplete() const { return incomplete_; }
  const std::string& lastIncompleteChannel() const { return last_incomplete_channel_; }

 private:
  struct Slot {
    std::uint64_t sender = 0;
    std::uint32_t seqno = 0;
    std::uint32_t size = 0;
    bool active = false;
    std::string channel;
    std::vector<std::uint8_t> data;
    std::vector<std::uint8_t> received;
    std::uint32_t remaining = 0;
    std::uint64_t last_use = 0;
  };
  Slot& slotFor(std::uint64_t sender);
  void abandon(Slot& slot);

  std::vector<Slot> slots_;
  std::uint64_t uses_ = 0;
  std::int64_t incomplete_ = 0;
  std::string last_incomplete_channel_;
};

// The senders (UDP source ports) whose later fragments a process takes when it does not take
// all of them (udpm_receiver.hpp): at most kMax, the least recently seen forgotten first to make
// room, and one not seen for kForget_us forgotten. Times are a monotonic clock's, in us.
class SenderPorts {
 public:
  static constexpr std::size_t kMax = 8;
  static constexpr std::int64_t kForget_us = 10'000'000;

  // `port` was seen at `now_us`: returns true (and refreshes it) if it is known.
  bool refresh(std::uint16_t port, std::int64_t now_us);
  // Adds `port` (not known) seen at `now_us`; appends the ports forgotten to make room to
  // `forgotten`.
  void add(std::uint16_t port, std::int64_t now_us, std::vector<std::uint16_t>& forgotten);
  // Whether expire() would forget a port.
  bool anyQuiet(std::int64_t now_us) const;
  // Forgets the ports not seen since `now_us` - kForget_us and appends them to `forgotten`.
  void expire(std::int64_t now_us, std::vector<std::uint16_t>& forgotten);
  void clear();
  // In the order learnt.
  const std::vector<std::uint16_t>& ports() const { return ports_; }

 private:
  void erase(std::size_t i, std::vector<std::uint16_t>& forgotten);

  std::vector<std::uint16_t> ports_;
  std::vector<std::int64_t> seen_us_;
};

// Offset of the UDP payload in what a socket filter of a UDP socket sees (the UDP header first).
inline constexpr std::uint32_t kFilterPayloadOffset = 8;

// Offset of the UDP source port in what a socket filter of a UDP socket sees.
inline constexpr std::uint32_t kFilterSourcePortOffset = 0;

// Which later fragments (fragment number > 0: no channel name) a filter passes.
struct LaterFragments {
  // Every one.
  bool all = false;
  // Otherwise those whose UDP source port (host byte order) is one of these.
  std::vector<std::uint16_t> from_ports;
};

// A classic BPF program for SO_ATTACH_FILTER that accepts a short message or a first fragment on
// one of `channels`, the later fragments `later` says, and drops everything else.
std::vector<sock_filter> filterProgram(const std::vector<std::string>& channels,
                                       const LaterFragments& later,
                                       std::uint32_t payload_offset = kFilterPayloadOffset);
// The same with every later fragment (`accept_later_fragments`) or none.
inline std::vector<sock_filter> filterProgram(const std::vector<std::string>& channels,
                                              bool accept_later_fragments,
                                              std::uint32_t payload_offset = kFilterPayloadOffset) {
  return filterProgram(channels, LaterFragments{.all = accept_later_fragments, .from_ports = {}},
                       payload_offset);
}

}  // namespace fieldline::bus::udpm
