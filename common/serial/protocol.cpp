#include "common/serial/protocol.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <boost/crc.hpp>

namespace fieldline::serial {
namespace {

constexpr std::size_t kHelloBody = 9;
constexpr std::size_t kCommandBody = 10;
constexpr std::size_t kOdometryBody = 30;
// Type 0x21: seq, controller time, wheel count (u8), the ticks, status, last command.
constexpr std::size_t kOdometryWheelsFixed = 4 + 8 + 1 + 2 + 4;
// ... with the wheel currents' tail (2 bytes per wheel) and/or the gyro's tail (4 bytes, after
// the currents).
constexpr std::size_t kOdometryGyroTail = 4;
constexpr std::size_t kErrorBody = 5;
constexpr std::size_t kHeaderSize = 2;
constexpr std::size_t kCrcSize = 4;

std::uint32_t crc32(std::span<const std::uint8_t> bytes) {
  boost::crc_32_type crc;
  crc.process_bytes(bytes.data(), bytes.size());
  return crc.checksum();
}

// Little-endian writers and readers, independent of the host's byte order.
class Writer {
 public:
  explicit Writer(std::vector<std::uint8_t>& out) : out_(out) {}
  void u8(std::uint8_t v) { out_.push_back(v); }
  void u16(std::uint16_t v) { le(v, 2); }
  void u32(std::uint32_t v) { le(v, 4); }
  void u64(std::uint64_t v) { le(v, 8); }
  void i16(std::int16_t v) { u16(static_cast<std::uint16_t>(v)); }
  void i32(std::int32_t v) { u32(static_cast<std::uint32_t>(v)); }

 private:
  void le(std::uint64_t v, int bytes) {
    for (int i = 0; i < bytes; ++i)
      out_.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  }
  std::vector<std::uint8_t>& out_;
};

class Reader {
 public:
  explicit Reader(std::span<const std::uint8_t> in) : in_(in) {}
  std::uint8_t u8() { return static_cast<std::uint8_t>(le(1)); }
  std::uint16_t u16() { return static_cast<std::uint16_t>(le(2)); }
  std::uint32_t u32() { return static_cast<std::uint32_t>(le(4)); }
  std::uint64_t u64() { return le(8); }
  std::int16_t i16() { return static_cast<std::int16_t>(u16()); }
  std::int32_t i32() { return static_cast<std::int32_t>(u32()); }

 private:
  std::uint64_t le(int bytes) {
    std::uint64_t v = 0;
    for (int i = 0; i < bytes; ++i)
      v |= static_cast<std::uint64_t>(in_[pos_++]) << (8 * i);
    return v;
  }
  std::span<const std::uint8_t> in_;
  std::size_t pos_ = 0;
};

void writeBody(const Hello& m, Writer& w) {
  w.u8(static_cast<std::uint8_t>(m.role));
  w.u16(m.firmware_version);
  w.u16(m.ticks_per_revolution);
  w.u32(m.odometry_period_us);
}
void writeBody(const VelocityCommand& m, Writer& w) {
  w.u32(m.seq);
  w.i16(m.vx_q15);
  w.i16(m.vy_q15);
  w.i16(m.omega_q15);
}
void writeBody(const OdometrySample& m, Writer& w) {
  if (m.ticks.size() < kMinWheels || (m.current_ma && m.current_ma->size() != m.ticks.size())) {
    throw std::invalid_argument("odometry sample: " + std::to_string(m.ticks.size()) + " wheels, " +
                                std::to_string(m.current_ma ? m.current_ma->size() : 0) +
                                " currents (3 or 4 wheels, a current for each)");
  }
  w.u32(m.seq);
  w.u64(m.controller_time_us);
  if (m.ticks.size() != 3) w.u8(static_cast<std::uint8_t>(m.ticks.size()));
  for (const auto t : m.ticks)
    w.i32(t);
  w.u16(m.status);
  w.u32(m.last_command_seq);
  if (m.current_ma) {
    for (const auto c : *m.current_ma)
      w.i16(c);
  }
  if (m.gyro_angle_urad) w.i32(*m.gyro_angle_urad);
}
void writeBody(const ErrorReport& m, Writer& w) {
  w.u8(static_cast<std::uint8_t>(m.code));
  w.u32(m.detail);
}

MessageType typeOf(const Message& m) {
  switch (m.index()) {
    case 0:
      return MessageType::kHello;
    case 1:
      return MessageType::kVelocityCommand;
    case 2:
      return std::get<OdometrySample>(m).ticks.size() == 3 ? MessageType::kOdometry
                                                           : MessageType::kOdometryWheels;
    default:
      return MessageType::kError;
  }
}

}  // namespace

std::int16_t toQ15(double value) {
  if (!std::isfinite(value)) return 0;
  return static_cast<std::int16_t>(std::lround(std::clamp(value, -1.0, 1.0) * 32767.0));
}

double fromQ15(std::int16_t value) {
  // -32768 is never sent; read it as -1 like the controller would.
  return std::max(-1.0, value / 32767.0);
}

void cobsEncode(std::span<const std::uint8_t> data, std::vector<std::uint8_t>& out) {
  std::size_t code_pos = out.size();
  out.push_back(0);
  std::uint8_t code = 1;
  for (const std::uint8_t byte : data) {
    if (byte != 0) {
      out.push_back(byte);
      ++code;
    }
    if (byte == 0 || code == 0xFF) {
      out[code_pos] = code;
      code_pos = out.size();
      out.push_back(0);
      code = 1;
    }
  }
  out[code_pos] = code;
}

bool cobsDecode(std::span<const std::uint8_t> frame, std::vector<std::uint8_t>& out) {
  out.clear();
  std::size_t i = 0;
  while (i < frame.size()) {
    const std::uint8_t code = frame[i++];
    if (code == 0) return false;
    const std::size_t run = code - 1u;
    if (i + run > frame.size()) return false;
    for (std::size_t k = 0; k < run; ++k) {
      if (frame[i + k] == 0) return false;
      out.push_back(frame[i + k]);
    }
    i += run;
    // A short run ends in an encoded zero, except at the end of the frame.
    if (code != 0xFF && i < frame.size()) out.push_back(0);
  }
  return true;
}

void encode(const Message& message, std::vector<std::uint8_t>& out) {
  std::vector<std::uint8_t> payload;
  payload.reserve(kMaxPayloadSize);
  Writer w(payload);
  w.u8(kVersion);
  w.u8(static_cast<std::uint8_t>(typeOf(message)));
  std::visit([&](const auto& m) { writeBody(m, w); }, message);
  w.u32(crc32(payload));
  cobsEncode(payload, out);
  out.push_back(kDelimiter);
}

std::vector<std::uint8_t> encode(const Message& message) {
  std::vector<std::uint8_t> out;
  encode(message, out);
  return out;
}

std::variant<Message, Reject> parsePayload(std::span<const std::uint8_t> payload) {
  if (payload.size() < kHeaderSize + kCrcSize) return Reject::kLength;
  const std::size_t body_size = payload.size() - kHeaderSize - kCrcSize;
  Reader crc_reader(payload.subspan(payload.size() - kCrcSize));
  if (crc_reader.u32() != crc32(payload.first(payload.size() - kCrcSize))) return Reject::kCrc;
  if (payload[0] != kVersion) return Reject::kVersion;
  Reader r(payload.subspan(kHeaderSize, body_size));
  switch (static_cast<MessageType>(payload[1])) {
    case MessageType::kHello: {
      if (body_size != kHelloBody) return Reject::kLength;
      Hello m;
      const std::uint8_t role = r.u8();
      if (role != static_cast<std::uint8_t>(Role::kHost) &&
          role != static_cast<std::uint8_t>(Role::kController)) {
        return Reject::kLength;
      }
      m.role = static_cast<Role>(role);
      m.firmware_version = r.u16();
      m.ticks_per_revolution = r.u16();
      m.odometry_period_us = r.u32();
      return Message{m};
    }
    case MessageType::kVelocityCommand: {
      if (body_size != kCommandBody) return Reject::kLength;
      VelocityCommand m;
      m.seq = r.u32();
      m.vx_q15 = r.i16();
      m.vy_q15 = r.i16();
      m.omega_q15 = r.i16();
      return Message{m};
    }
    case MessageType::kOdometry:
    case MessageType::kOdometryWheels: {
      // 0x20: three wheels; 0x21: the wheel count is the byte after the controller time.
      const bool counted = static_cast<MessageType>(payload[1]) == MessageType::kOdometryWheels;
      std::size_t wheels = 3;
      std::size_t fixed = kOdometryBody;
      if (counted) {
        if (body_size < kOdometryWheelsFixed) return Reject::kLength;
        wheels = payload[kHeaderSize + 12];
        if (wheels < kMinWheels || wheels > kMaxWheels) return Reject::kLength;
        fixed = kOdometryWheelsFixed + 4 * wheels;
      }
      // Optional tails: the currents (2 bytes per wheel), then the gyro (4 bytes).
      const std::size_t currents_tail = 2 * wheels;
      const std::size_t tail = body_size - std::min(body_size, fixed);
      const bool currents = tail == currents_tail || tail == currents_tail + kOdometryGyroTail;
      const bool gyro = tail == kOdometryGyroTail || tail == currents_tail + kOdometryGyroTail;
      if (body_size < fixed || (tail != 0 && !currents && !gyro)) return Reject::kLength;
      OdometrySample m;
      m.seq = r.u32();
      m.controller_time_us = r.u64();
      if (counted) r.u8();
      m.ticks.clear();
      for (std::size_t i = 0; i < wheels; ++i)
        m.ticks.push_back(r.i32());
      m.status = r.u16();
      m.last_command_seq = r.u32();
      if (currents) {
        PerWheel<std::int16_t> current;
        for (std::size_t i = 0; i < wheels; ++i)
          current.push_back(r.i16());
        m.current_ma = current;
      }
      if (gyro) m.gyro_angle_urad = r.i32();
      return Message{m};
    }
    case MessageType::kError: {
      if (body_size != kErrorBody) return Reject::kLength;
      ErrorReport m;
      m.code = static_cast<ErrorCode>(r.u8());
      m.detail = r.u32();
      return Message{m};
    }
  }
  return Reject::kUnknownType;
}

std::string_view rejectName(Reject reason) {
  switch (reason) {
    case Reject::kCobs:
      return "serial_cobs";
    case Reject::kCrc:
      return "serial_crc";
    case Reject::kLength:
      return "serial_length";
    case Reject::kVersion:
      return "serial_version";
    case Reject::kUnknownType:
      return "serial_unknown_type";
    case Reject::kOversize:
      return "serial_oversize";
  }
  return "serial_unknown";
}

Decoder::Decoder() {
  frame_.reserve(kMaxFrameSize);
  payload_.reserve(kMaxFrameSize);
}

void Decoder::reset() {
  frame_.clear();
  skipping_ = false;
}

void Decoder::rejectFrame(Reject reason, std::size_t bytes) {
  switch (reason) {
    case Reject::kCobs:
      ++stats_.cobs_errors;
      break;
    case Reject::kCrc:
      ++stats_.crc_errors;
      break;
    case Reject::kLength:
      ++stats_.length_errors;
      break;
    case Reject::kVersion:
      ++stats_.version_errors;
      break;
    case Reject::kUnknownType:
      ++stats_.unknown_type_errors;
      break;
    case Reject::kOversize:
      ++stats_.oversize_errors;
      break;
  }
  stats_.bytes_discarded += bytes;
  rejected_any_ = true;
  last_reject_ = reason;
}

void Decoder::finishFrame(std::vector<Message>& out, std::size_t& added) {
  // Back-to-back delimiters are idle filler, not an error.
  if (frame_.empty()) return;
  if (!cobsDecode(frame_, payload_)) {
    rejectFrame(Reject::kCobs, frame_.size());
  } else {
    auto parsed = parsePayload(payload_);
    if (auto* m = std::get_if<Message>(&parsed)) {
      out.push_back(*m);
      ++added;
      ++stats_.frames_ok;
    } else {
      rejectFrame(std::get<Reject>(parsed), frame_.size());
    }
  }
  frame_.clear();
}

std::size_t Decoder::feed(std::span<const std::uint8_t> bytes, std::vector<Message>& out) {
  std::size_t added = 0;
  stats_.bytes_received += bytes.size();
  for (const std::uint8_t byte : bytes) {
    if (byte == kDelimiter) {
      if (skipping_) {
        skipping_ = false;
      } else {
        finishFrame(out, added);
      }
      continue;
    }
    if (skipping_) {
      ++stats_.bytes_discarded;
      continue;
    }
    frame_.push_back(byte);
    if (frame_.size() > kMaxFrameSize) {
      // No valid frame is this long: drop it and everything up to the next delimiter.
      rejectFrame(Reject::kOversize, frame_.size());
      frame_.clear();
      skipping_ = true;
    }
  }
  return added;
}

}  // namespace fieldline::serial
