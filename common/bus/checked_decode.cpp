#include "common/bus/checked_decode.hpp"

#include <tuple>

#include <fmt/format.h>

namespace fieldline::bus {
namespace {

// Every channel of channels.hpp, to find a name's type at run time.
constexpr auto kAllChannels =
    std::make_tuple(channels::kCameraImage, channels::kVisionLines, channels::kVisionBall,
                    channels::kVisionObstacles, channels::kFieldFeatures, channels::kOdometry,
                    channels::kMotionCommand, channels::kRobotState, channels::kBallState,
                    channels::kTeamState, channels::kServiceStatus, channels::kSimWorld,
                    channels::kRecordingInfo, channels::kCameraPreview);

static_assert(std::tuple_size_v<decltype(kAllChannels)> == kAllChannelNames.size(),
              "every channel of channels.hpp belongs in kAllChannels");

// Without `now`, only decoded and validated.
template <typename Msg>
std::optional<Rejection> checkAs(const void* data, int size, std::optional<Utime> now,
                                 Utime tolerance) {
  // One decoded object per type and thread, reused: logs are mostly big images.
  thread_local Msg msg{};
  if (auto rejection = decodeChecked(msg, data, size)) return rejection;
  if (!now) return std::nullopt;
  return checkNotFromFuture(msg.header, *now, tolerance);
}

std::optional<Rejection> checkByChannel(std::string_view channel, const void* data, int size,
                                        std::optional<Utime> now, Utime future_tolerance) {
  std::optional<Rejection> result;
  bool known = false;
  std::apply(
      [&](const auto&... c) {
        ((!known && c.name == channel
              ? void((known = true,
                      result = checkAs<typename std::remove_cvref_t<decltype(c)>::Message>(
                          data, size, now, future_tolerance)))
              : void()),
         ...);
      },
      kAllChannels);
  if (!known)
    return Rejection{"unknown_channel",
                     "no fieldline channel is named '" + std::string(channel) + "'"};
  return result;
}

}  // namespace

namespace detail {

std::optional<std::int64_t> fingerprintOf(const void* data, int size) {
  if (data == nullptr || size < 8) return std::nullopt;
  const auto* p = static_cast<const std::uint8_t*>(data);
  std::uint64_t v = 0;
  for (int i = 0; i < 8; ++i)
    v = (v << 8) | p[i];
  return static_cast<std::int64_t>(v);
}

std::string_view typeWithFingerprint(std::int64_t fingerprint) {
  std::string_view name;
  std::apply(
      [&](const auto&... channel) {
        ((name.empty() && std::remove_cvref_t<decltype(channel)>::Message::getHash() == fingerprint
              ? void(name = std::remove_cvref_t<decltype(channel)>::Message::getTypeName())
              : void()),
         ...);
      },
      kAllChannels);
  return name;
}

}  // namespace detail

std::optional<Rejection> decodeCheckedView(ImageView& out, const void* data, int size) {
  // What image_t::decode reads, in its order (lcmtypes/image_t.lcm), but the pixels: a change of
  // the type changes its fingerprint, and this then refuses every message to the decoder below.
  image_t& m = out.fields;
  const int n = size;
  int pos = 0;
  const auto read = [&](int used) {
    if (used < 0) return false;
    pos += used;
    return true;
  };
  std::int64_t hash = 0;
  const bool fast = n >= 0 && read(__int64_t_decode_array(data, 0, n, &hash, 1)) &&
                    hash == image_t::getHash() &&
                    read(m.header._decodeNoHash(data, pos, n - pos)) &&
                    read(__int32_t_decode_array(data, pos, n - pos, &m.width, 1)) &&
                    read(__int32_t_decode_array(data, pos, n - pos, &m.height, 1)) &&
                    read(__int32_t_decode_array(data, pos, n - pos, &m.stride, 1)) &&
                    read(__int8_t_decode_array(data, pos, n - pos, &m.format, 1)) &&
                    read(__int8_t_decode_array(data, pos, n - pos, &m.source, 1)) &&
                    read(__int64_t_decode_array(data, pos, n - pos, &m.frame_number, 1)) &&
                    read(__int32_t_decode_array(data, pos, n - pos, &m.exposure_us, 1)) &&
                    read(__int32_t_decode_array(data, pos, n - pos, &m.size, 1)) && m.size >= 0 &&
                    m.size == n - pos;
  if (!fast) {
    // Not a whole image_t: the decoder's own verdict, kind and text (or, should it read one,
    // the message as it reads it).
    if (auto rejection = decodeChecked(m, data, size)) return rejection;
    out.data = std::span<const std::uint8_t>(m.data);
    return std::nullopt;
  }
  m.data.clear();
  if (auto problem = validateImageFields(m)) return Rejection{"invalid", *problem};
  out.data = std::span<const std::uint8_t>(static_cast<const std::uint8_t*>(data) + pos,
                                           static_cast<std::size_t>(m.size));
  return std::nullopt;
}

std::optional<Rejection> checkNotFromFuture(const header_t& header, Utime now, Utime tolerance) {
  // In long double: a log's stamp or a header may be near INT64_MAX, where now + tolerance and
  // utime - now overflow (a log stamp of INT64_MAX read as "-9221575747911036 ms in the future").
  const long double ahead = static_cast<long double>(header.utime) - static_cast<long double>(now);
  if (ahead > static_cast<long double>(tolerance)) {
    return Rejection{"future_utime",
                     fmt::format("utime {} is {:.0f} ms in the future (now {})", header.utime,
                                 static_cast<double>(ahead / 1000.0L), now)};
  }
  return std::nullopt;
}

std::optional<Rejection> checkEncoded(std::string_view channel, const void* data, int size,
                                      Utime now, Utime future_tolerance) {
  return checkByChannel(channel, data, size, now, future_tolerance);
}

std::optional<Rejection> checkDecodes(std::string_view channel, const void* data, int size) {
  return checkByChannel(channel, data, size, std::nullopt, 0);
}

}  // namespace fieldline::bus
