// The serial protocol between the host (motor_bridge) and the motor controller: binary frames,
// COBS-framed with a 0x00 delimiter and protected by CRC-32. Specification:
// docs/serial-protocol.md. This header is the whole implementation's interface; it knows
// nothing of devices or time.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string_view>
#include <variant>
#include <vector>

#include <boost/container/static_vector.hpp>

namespace fieldline::serial {

// Bumped on any incompatible change of a message layout.
inline constexpr std::uint8_t kVersion = 1;
inline constexpr std::uint8_t kDelimiter = 0x00;

enum class MessageType : std::uint8_t {
  kHello = 0x01,
  kVelocityCommand = 0x10,
  // Three wheels (the compact form every controller of version 1 sends).
  kOdometry = 0x20,
  // Any supported number of wheels (3 or 4): the wheel count is in the body.
  kOdometryWheels = 0x21,
  kError = 0x30,
};

// Who sent a Hello.
enum class Role : std::uint8_t { kHost = 1, kController = 2 };

// Sent by both sides after connecting; the controller answers a host's Hello with its own.
struct Hello {
  Role role = Role::kHost;
  std::uint16_t firmware_version = 0;
  // Encoder ticks per wheel revolution (768 on the seed's robot); 0 from the host.
  std::uint16_t ticks_per_revolution = 0;
  // Odometry sample period [µs]; 0 from the host.
  std::uint32_t odometry_period_us = 0;

  bool operator==(const Hello&) const = default;
};

// Host -> controller: the desired body velocity, normalised to the robot's top speeds.
struct VelocityCommand {
  // Increases by one per command; echoed in OdometrySample::last_command_seq.
  std::uint32_t seq = 0;
  // Forward, left and CCW rotation as fractions of the top speed in [-1, 1], sent as Q15
  // (value * 32767, rounded): see toQ15 / fromQ15.
  std::int16_t vx_q15 = 0;
  std::int16_t vy_q15 = 0;
  std::int16_t omega_q15 = 0;

  bool operator==(const VelocityCommand&) const = default;
};

// Status bits of an odometry sample.
inline constexpr std::uint16_t kStatusWatchdog = 1 << 0;    // motors stopped by the watchdog
inline constexpr std::uint16_t kStatusMotorFault = 1 << 1;  // over-current or driver fault
inline constexpr std::uint16_t kStatusRxErrors = 1 << 2;    // bad frames since the last sample
inline constexpr std::uint16_t kStatusReset = 1 << 3;  // first sample since the controller started

// The wheel counts a controller may report (a robot drives on three or four omni wheels).
inline constexpr std::size_t kMinWheels = 3;
inline constexpr std::size_t kMaxWheels = 4;
template <typename T>
using PerWheel = boost::container::static_vector<T, kMaxWheels>;

// Controller -> host at the odometry rate (50 Hz). Three wheels go out as type 0x20, four (or
// any count) as 0x21 with the count in the body (docs/serial-protocol.md).
struct OdometrySample {
  // Increases by one per sample; a gap means lost samples (ticks still accumulate).
  std::uint32_t seq = 0;
  // Controller clock at sampling [µs since the controller started].
  std::uint64_t controller_time_us = 0;
  // Accumulated encoder ticks per wheel (3 or 4 wheels; three unless set), wrapping as int32.
  PerWheel<std::int32_t> ticks{0, 0, 0};
  std::uint16_t status = 0;
  // seq of the last valid command the controller accepted (0 before the first).
  std::uint32_t last_command_seq = 0;
  // Mean motor current per wheel over the sample period [mA], signed like the wheel's drive
  // direction, one per wheel: an optional tail of the body (a three-wheeled controller without
  // current sensing sends the 30-byte body, one with it 36 bytes; docs/serial-protocol.md).
  std::optional<PerWheel<std::int16_t>> current_ma;
  // The yaw-rate gyro's integrated angle since the controller started [µrad CCW], wrapping as
  // int32 like the ticks, so a lost frame loses no rotation: the host takes the difference. An
  // optional tail after the currents (4 more bytes: 34-byte body without currents, 40 with them;
  // docs/serial-protocol.md).
  std::optional<std::int32_t> gyro_angle_urad;

  bool operator==(const OdometrySample&) const = default;
};

enum class ErrorCode : std::uint8_t {
  kBadFrame = 1,            // detail: bad frames received so far
  kUnsupportedVersion = 2,  // detail: the version byte received
  kUnknownType = 3,         // detail: the type byte received
};

// Controller -> host when it discards input.
struct ErrorReport {
  ErrorCode code = ErrorCode::kBadFrame;
  std::uint32_t detail = 0;

  bool operator==(const ErrorReport&) const = default;
};

using Message = std::variant<Hello, VelocityCommand, OdometrySample, ErrorReport>;

// Q15 conversion: clamps to [-1, 1]; NaN maps to 0 (callers reject NaN before sending).
std::int16_t toQ15(double value);
double fromQ15(std::int16_t value);

// Largest payload (version + type + body + CRC) of any message, and of its COBS frame with the
// delimiter. Anything longer on the wire is garbage.
// The longest body: type 0x21 with four wheels and both tails (19 + 4 * 4 + 2 * 4 + 4 bytes).
inline constexpr std::size_t kMaxPayloadSize = 2 + 47 + 4;
inline constexpr std::size_t kMaxFrameSize = kMaxPayloadSize + kMaxPayloadSize / 254 + 2;

// Appends the complete frame (COBS bytes and the 0x00 delimiter) for `message` to `out`. Throws
// std::invalid_argument for an odometry sample without 3 or 4 ticks or with currents for
// another number of wheels.
void encode(const Message& message, std::vector<std::uint8_t>& out);
std::vector<std::uint8_t> encode(const Message& message);

// COBS (Cheshire and Baker 1999): `data` without zeros, one byte longer per 254 bytes.
void cobsEncode(std::span<const std::uint8_t> data, std::vector<std::uint8_t>& out);
// Inverse of cobsEncode for one frame without its delimiter; false if malformed.
bool cobsDecode(std::span<const std::uint8_t> frame, std::vector<std::uint8_t>& out);

// What the decoder threw away, and why. Counters since construction.
struct DecoderStats {
  std::uint64_t frames_ok = 0;
  std::uint64_t bytes_received = 0;
  // Bytes of every rejected frame (not counting delimiters).
  std::uint64_t bytes_discarded = 0;
  std::uint64_t cobs_errors = 0;
  std::uint64_t crc_errors = 0;
  // Too short for a header and CRC, or a body length that does not fit its type.
  std::uint64_t length_errors = 0;
  std::uint64_t version_errors = 0;
  std::uint64_t unknown_type_errors = 0;
  // Runs longer than kMaxFrameSize without a delimiter.
  std::uint64_t oversize_errors = 0;

  std::uint64_t badFrames() const {
    return cobs_errors + crc_errors + length_errors + version_errors + unknown_type_errors +
           oversize_errors;
  }
};

// Why a frame was rejected (for logs and counters).
enum class Reject { kCobs, kCrc, kLength, kVersion, kUnknownType, kOversize };
std::string_view rejectName(Reject reason);

// A streaming decoder: feed it bytes as they arrive, in pieces of any size; every complete
// valid frame comes out once, every invalid one is counted and dropped, and decoding resumes at
// the next delimiter. Allocates only while its buffers grow to kMaxFrameSize.
class Decoder {
 public:
  Decoder();

  // Decodes what `bytes` completes; appends messages to `out`, returns how many were added.
  std::size_t feed(std::span<const std::uint8_t> bytes, std::vector<Message>& out);
  // Drops a partial frame (after a reconnect).
  void reset();

  const DecoderStats& stats() const { return stats_; }
  // Reason of the most recent rejection, if any frame was rejected yet.
  bool hasRejected() const { return rejected_any_; }
  Reject lastReject() const { return last_reject_; }

 private:
  void finishFrame(std::vector<Message>& out, std::size_t& added);
  void rejectFrame(Reject reason, std::size_t bytes);

  std::vector<std::uint8_t> frame_;
  std::vector<std::uint8_t> payload_;
  bool skipping_ = false;
  DecoderStats stats_;
  bool rejected_any_ = false;
  Reject last_reject_ = Reject::kCobs;
};

// Parses one payload (after COBS decoding). Returns the reason on failure.
std::variant<Message, Reject> parsePayload(std::span<const std::uint8_t> payload);

}  // namespace fieldline::serial
