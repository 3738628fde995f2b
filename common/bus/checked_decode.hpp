// The checks every received message passes before anyone uses it, shared by live traffic
// (bus::Node) and logs (bus::LogReader): decode into the channel's type, validate (validate.hpp),
// and no utime from the future. A failed check names its kind ("decode", "wrong_type",
// "invalid", "future_utime") and what was wrong.
#pragma once

#include <cstdint>
#include <exception>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "common/bus/channels.hpp"
#include "common/bus/validate.hpp"
#include "common/time/clock.hpp"

namespace fieldline::bus {

struct Rejection {
  // Short machine-readable reason, the error kind in SERVICE_STATUS.
  std::string kind;
  // What was wrong, for a person.
  std::string text;
};

namespace detail {
// The 8-byte big-endian type fingerprint every encoded LCM message starts with.
std::optional<std::int64_t> fingerprintOf(const void* data, int size);
// The fieldline type whose fingerprint this is ("odometry_t"), or empty for none.
std::string_view typeWithFingerprint(std::int64_t fingerprint);
}  // namespace detail

// Decodes `data` into `msg` (reused, so big messages decode without allocating) and validates it.
// A message of another fieldline type is "wrong_type", other undecodable bytes "decode".
template <typename Msg>
std::optional<Rejection> decodeChecked(Msg& msg, const void* data, int size) {
  bool decoded = false;
  try {
    decoded = msg.decode(data, 0, size) == size;
  } catch (const std::exception&) {  // e.g. bad_alloc for an absurd array count
    decoded = false;
  }
  if (!decoded) {
    const auto fingerprint = detail::fingerprintOf(data, size);
    if (fingerprint && *fingerprint != Msg::getHash()) {
      const std::string_view other = detail::typeWithFingerprint(*fingerprint);
      if (!other.empty()) {
        return Rejection{"wrong_type",
                         "a " + std::string(other) + " where " + Msg::getTypeName() + " belongs"};
      }
    }
    return Rejection{"decode", "undecodable message of " + std::to_string(size) + " bytes"};
  }
  if (auto problem = validate(msg)) return Rejection{"invalid", *problem};
  return std::nullopt;
}

// CAMERA_IMAGE without its pixels copied: every field of the message but `data`, and a view of
// the pixel bytes where they arrived (the receive buffer, valid while the handler runs).
struct ImageView {
  // `data` is left empty (unless the message could only be read by image_t's own decoder).
  image_t fields;
  std::span<const std::uint8_t> data;
};

// decodeChecked() for an image_t into an ImageView: the same checks with the same outcome (a
// rejection is decodeChecked's, with its kind and text), but the pixels are not copied.
std::optional<Rejection> decodeCheckedView(ImageView& out, const void* data, int size);

// A message stamped more than `tolerance` after `now` describes something that has not happened.
std::optional<Rejection> checkNotFromFuture(const header_t& header, Utime now, Utime tolerance);

// decodeChecked() and checkNotFromFuture() for an event on any channel of channels.hpp, decoded
// into the type that channel carries; "unknown_channel" for a name not in the table.
std::optional<Rejection> checkEncoded(std::string_view channel, const void* data, int size,
                                      Utime now, Utime future_tolerance);
// decodeChecked() alone for an event on any channel of channels.hpp (no clock involved):
// "decode", "wrong_type", "invalid" or "unknown_channel".
std::optional<Rejection> checkDecodes(std::string_view channel, const void* data, int size);

}  // namespace fieldline::bus
