#include "common/bus/udpm_wire.hpp"

#include <algorithm>
#include <cstring>
#include <stdexcept>

namespace fieldline::bus::udpm {
namespace {

std::uint32_t be32(const std::uint8_t* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) |
         std::uint32_t{p[3]};
}

std::uint16_t be16(const std::uint8_t* p) {
  return static_cast<std::uint16_t>((p[0] << 8) | p[1]);
}

// The NUL-terminated channel name at the start of `bytes`; false if it has no terminator within
// the longest name LCM allows.
bool readChannel(std::span<const std::uint8_t> bytes, std::string_view& channel) {
  const std::size_t limit = std::min(bytes.size(), kMaxChannelLength + 1);
  const auto* end = static_cast<const std::uint8_t*>(std::memchr(bytes.data(), 0, limit));
  if (end == nullptr) return false;
  channel = std::string_view(reinterpret_cast<const char*>(bytes.data()),
                             static_cast<std::size_t>(end - bytes.data()));
  return true;
}

}  // namespace

const char* parseDatagram(std::span<const std::uint8_t> bytes, Datagram& out) {
  if (bytes.size() < kShortHeaderBytes) return "shorter than an LCM header";
  const std::uint32_t magic = be32(bytes.data());
  out.seqno = be32(bytes.data() + 4);
  out.channel = {};
  if (magic == kMagicShort) {
    out.fragment = false;
    auto rest = bytes.subspan(kShortHeaderBytes);
    if (!readChannel(rest, out.channel)) return "channel name without its end within 63 bytes";
    out.bytes = rest.subspan(out.channel.size() + 1);
    out.message_size = static_cast<std::uint32_t>(out.bytes.size());
    out.offset = 0;
    out.fragment_no = 0;
    out.fragment_count = 1;
    return nullptr;
  }
  if (magic != kMagicFragment) return "not an LCM datagram (magic is neither LC02 nor LC03)";
  if (bytes.size() < kFragmentHeaderBytes) return "shorter than an LCM fragment header";
  out.fragment = true;
  out.message_size = be32(bytes.data() + 8);
  out.offset = be32(bytes.data() + 12);
  out.fragment_no = be16(bytes.data() + 16);
  out.fragment_count = be16(bytes.data() + 18);
  auto rest = bytes.subspan(kFragmentHeaderBytes);
  if (out.fragment_no == 0) {
    if (!readChannel(rest, out.channel)) return "channel name without its end within 63 bytes";
    rest = rest.subspan(out.channel.size() + 1);
  }
  out.bytes = rest;
  if (out.message_size > kMaxMessageBytes) return "fragmented message larger than 256 MB";
  if (out.fragment_count == 0 || out.fragment_no >= out.fragment_count) {
    return "fragment number beyond the fragment count";
  }
  if (std::uint64_t{out.offset} + out.bytes.size() > out.message_size) {
    return "fragment reaches beyond its message's size";
  }
  return nullptr;
}

FragmentAssembler::Slot& FragmentAssembler::slotFor(std::uint64_t sender) {
  // A few senders of big messages per bus (a camera, a viewer's preview): a linear search.
  constexpr std::size_t kMaxSenders = 8;
  ++uses_;
  for (Slot& s : slots_) {
    if (s.sender == sender) {
      s.last_use = uses_;
      return s;
    }
  }
  if (slots_.size() < kMaxSenders) {
    slots_.emplace_back();
    slots_.back().sender = sender;
    slots_.back().last_use = uses_;
    return slots_.back();
  }
  Slot& oldest = *std::min_element(slots_.begin(), slots_.end(), [](const Slot& a, const Slot& b) {
    return a.last_use < b.last_use;
  });
  abandon(oldest);
  oldest.sender = sender;
  oldest.last_use = uses_;
  return oldest;
}

void FragmentAssembler::abandon(Slot& slot) {
  // Without its first fragment the message was one this process does not read (the socket
  // filter passes a sender's later fragments of every channel), or one already refused and
  // counted when its first fragment came (udpm_receiver.cpp): nothing more was lost for us.
  if (slot.active && !slot.channel.empty()) {
    ++incomplete_;
    last_incomplete_channel_ = slot.channel;
  }
  slot.active = false;
}

void FragmentAssembler::giveUp(std::uint64_t sender) {
  for (Slot& s : slots_)
    if (s.sender == sender) abandon(s);
}

void FragmentAssembler::giveUpPort(std::uint16_t port) {
  for (Slot& s : slots_)
    if ((s.sender & 0xffffu) == port) abandon(s);
}

FragmentAssembler::Outcome FragmentAssembler::add(std::uint64_t sender, const Datagram& d,
                                                  Message& message) {
  if (d.fragment_count == 0 || d.fragment_no >= d.fragment_count ||
      std::uint64_t{d.offset} + d.bytes.size() > d.message_size ||
      d.message_size > kMaxMessageBytes) {
    return Outcome::kInvalid;
  }
  Slot& slot = slotFor(sender);
  if (slot.active && (slot.seqno != d.seqno || slot.size != d.message_size ||
                      slot.received.size() != d.fragment_count)) {
    abandon(slot);
  }
  if (!slot.active) {
    slot.active = true;
    slot.seqno = d.seqno;
    slot.size = d.message_size;
    slot.channel.clear();
    slot.data.resize(d.message_size);
    slot.received.assign(d.fragment_count, 0);
    slot.remaining = d.fragment_count;
  }
  auto& seen = slot.received[d.fragment_no];
  if (seen) return Outcome::kPending;  // a duplicate
  seen = 1;
  std::copy(d.bytes.begin(), d.bytes.end(), slot.data.begin() + d.offset);
  if (d.fragment_no == 0) slot.channel.assign(d.channel);
  if (--slot.remaining > 0) return Outcome::kPending;
  slot.active = false;
  message.channel = slot.channel;
  message.bytes = std::span<const std::uint8_t>(slot.data.data(), slot.size);
  return Outcome::kComplete;
}

bool SenderPorts::refresh(std::uint16_t port, std::int64_t now_us) {
  const auto it = std::find(ports_.begin(), ports_.end(), port);
  if (it == ports_.end()) return false;
  seen_us_[static_cast<std::size_t>(it - ports_.begin())] = now_us;
  return true;
}

void SenderPorts::add(std::uint16_t port, std::int64_t now_us,
                      std::vector<std::uint16_t>& forgotten) {
  expire(now_us, forgotten);
  if (ports_.size() >= kMax) {
    const auto least = std::min_element(seen_us_.begin(), seen_us_.end());
    erase(static_cast<std::size_t>(least - seen_us_.begin()), forgotten);
  }
  ports_.push_back(port);
  seen_us_.push_back(now_us);
}

bool SenderPorts::anyQuiet(std::int64_t now_us) const {
  return std::any_of(seen_us_.begin(), seen_us_.end(),
                     [&](std::int64_t seen) { return now_us - seen > kForget_us; });
}

void SenderPorts::expire(std::int64_t now_us, std::vector<std::uint16_t>& forgotten) {
  for (std::size_t i = ports_.size(); i-- > 0;)
    if (now_us - seen_us_[i] > kForget_us) erase(i, forgotten);
}

void SenderPorts::clear() {
  ports_.clear();
  seen_us_.clear();
}

void SenderPorts::erase(std::size_t i, std::vector<std::uint16_t>& forgotten) {
  forgotten.push_back(ports_[i]);
  ports_.erase(ports_.begin() + static_cast<std::ptrdiff_t>(i));
  seen_us_.erase(seen_us_.begin() + static_cast<std::ptrdiff_t>(i));
}

std::vector<sock_filter> filterProgram(const std::vector<std::string>& channels,
                                       const LaterFragments& later, std::uint32_t payload_offset) {
  constexpr std::uint32_t kAccept = 0xffffffffu;  // keep the whole datagram
  constexpr std::uint32_t kDrop = 0;
  std::vector<sock_filter> p;
  const auto stmt = [&](std::uint16_t code, std::uint32_t k) {
    p.push_back(sock_filter{code, 0, 0, k});
  };
  const auto jump = [&](std::uint16_t code, std::uint32_t k, std::uint8_t jt, std::uint8_t jf) {
    p.push_back(sock_filter{code, jt, jf, k});
  };
  // One block per channel: compare the name and its terminating NUL in words, a half word and
  // a byte; on a mismatch go on to the next block, on a match accept. Blocks stay short (at most
  // 33 instructions), so every jump fits classic BPF's 8-bit offsets.
  const auto channelBlocks = [&](std::uint32_t at) {
    for (const std::string& name : channels) {
      std::string bytes = name;
      bytes.push_back('\0');
      struct Chunk {
        std::uint16_t size_code;
        std::uint32_t offset;
        std::uint32_t value;
      };
      std::vector<Chunk> chunks;
      std::size_t i = 0;
      const auto byte = [&](std::size_t k) { return static_cast<std::uint8_t>(bytes[k]); };
      while (bytes.size() - i >= 4) {
        chunks.push_back({BPF_W, static_cast<std::uint32_t>(i),
                          (std::uint32_t{byte(i)} << 24) | (std::uint32_t{byte(i + 1)} << 16) |
                              (std::uint32_t{byte(i + 2)} << 8) | byte(i + 3)});
        i += 4;
      }
      if (bytes.size() - i >= 2) {
        chunks.push_back(
            {BPF_H, static_cast<std::uint32_t>(i), (std::uint32_t{byte(i)} << 8) | byte(i + 1)});
        i += 2;
      }
      if (bytes.size() - i == 1) chunks.push_back({BPF_B, static_cast<std::uint32_t>(i), byte(i)});
      const std::size_t block = 2 * chunks.size() + 1;
      for (std::size_t j = 0; j < chunks.size(); ++j) {
        stmt(BPF_LD | chunks[j].size_code | BPF_ABS, at + chunks[j].offset);
        jump(BPF_JMP | BPF_JEQ | BPF_K, chunks[j].value, 0,
             static_cast<std::uint8_t>(block - 2 * j - 2));
      }
      stmt(BPF_RET | BPF_K, kAccept);
    }
    stmt(BPF_RET | BPF_K, kDrop);
  };
  stmt(BPF_LD | BPF_W | BPF_ABS, payload_offset);         // 0: the magic
  jump(BPF_JMP | BPF_JEQ | BPF_K, kMagicFragment, 0, 1);  // 1: a fragment: 2, else 3
  const std::size_t fragment_jump = p.size();
  stmt(BPF_JMP | BPF_JA, 0);                           // 2: to the fragments' part
  jump(BPF_JMP | BPF_JEQ | BPF_K, kMagicShort, 1, 0);  // 3: a short message: 5
  stmt(BPF_RET | BPF_K, kDrop);                        // 4: not LCM
  channelBlocks(payload_offset + kShortHeaderBytes);   // 5...
  p[fragment_jump].k = static_cast<std::uint32_t>(p.size() - fragment_jump - 1);
  stmt(BPF_LD | BPF_H | BPF_ABS, payload_offset + 16);  // the fragment number
  const std::size_t first_jump = p.size();
  jump(BPF_JMP | BPF_JEQ | BPF_K, 0, 0, 0);  // the first: its channel (jt set below)
  if (later.all || later.from_ports.empty()) {
    stmt(BPF_RET | BPF_K, later.all ? kAccept : kDrop);
  } else {
    // A later fragment: accepted from the senders given (a handful: the 8-bit jumps fit).
    const std::size_t n = later.from_ports.size();
    if (n > 200) throw std::invalid_argument("socket filter: too many senders of fragments");
    stmt(BPF_LD | BPF_H | BPF_ABS, kFilterSourcePortOffset);
    for (std::size_t i = 0; i < n; ++i) {
      jump(BPF_JMP | BPF_JEQ | BPF_K, later.from_ports[i], static_cast<std::uint8_t>(n - i), 0);
    }
    stmt(BPF_RET | BPF_K, kDrop);
    stmt(BPF_RET | BPF_K, kAccept);
  }
  p[first_jump].jt = static_cast<std::uint8_t>(p.size() - first_jump - 1);
  channelBlocks(payload_offset + kFragmentHeaderBytes);
  return p;
}

}  // namespace fieldline::bus::udpm
