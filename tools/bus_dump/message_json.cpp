#include "tools/bus_dump/message_json.hpp"

#include <cmath>
#include <concepts>
#include <cstddef>
#include <exception>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "common/bus/channels.hpp"
#include "tools/bus_dump/message_writers_generated.hpp"
#include "tools/json/json_text.hpp"

namespace fieldline::bus_dump {
namespace {

// The channels of channels.hpp and their types; the writers themselves are generated from
// lcmtypes/ (gen_message_writers.py), so every field of every type is printed.
constexpr auto kChannels = std::make_tuple(
    bus::channels::kCameraImage, bus::channels::kVisionLines, bus::channels::kVisionBall,
    bus::channels::kVisionObstacles, bus::channels::kFieldFeatures, bus::channels::kOdometry,
    bus::channels::kMotionCommand, bus::channels::kRobotState, bus::channels::kBallState,
    bus::channels::kTeamState, bus::channels::kServiceStatus, bus::channels::kSimWorld,
    bus::channels::kRecordingInfo, bus::channels::kCameraPreview);
static_assert(std::tuple_size_v<decltype(kChannels)> == bus::kAllChannelNames.size(),
              "every channel of channels.hpp needs a JSON writer");

template <typename Msg>
bool decode(Msg& msg, const void* data, int size) {
  try {
    return msg.decode(data, 0, size) == size;
  } catch (const std::exception&) {
    return false;
  }
}

// Calls `f(Msg*)` with the type `channel` carries; false for an unknown channel.
template <typename F>
bool withChannelType(std::string_view channel, F&& f) {
  bool known = false;
  std::apply(
      [&](const auto&... c) {
        ((!known && c.name == channel
              ? void((known = true,
                      f(static_cast<typename std::remove_cvref_t<decltype(c)>::Message*>(nullptr))))
              : void()),
         ...);
      },
      kChannels);
  return known;
}

}  // namespace

std::uint64_t fnv1a64(const std::uint8_t* data, std::size_t size) {
  std::uint64_t hash = 0xcbf29ce484222325ULL;
  for (std::size_t i = 0; i < size; ++i) {
    hash ^= data[i];
    hash *= 0x100000001b3ULL;
  }
  return hash;
}

bool appendMessageJson(std::string& out, std::string_view channel, const void* data, int size,
                       const JsonOptions& options) {
  bool written = false;
  withChannelType(channel, [&](auto* type) {
    std::remove_pointer_t<decltype(type)> msg{};
    if (!decode(msg, data, size)) return;
    generated::write(out, msg, options);
    written = true;
  });
  return written;
}

bool appendCsvHeader(std::string& out, std::string_view channel) {
  return withChannelType(channel, [&](auto* type) {
    out += "log_utime,";
    generated::csvHeader(out, type);
  });
}

bool appendCsvRow(std::string& out, std::string_view channel, std::int64_t log_utime,
                  const void* data, int size, const JsonOptions& options) {
  bool written = false;
  withChannelType(channel, [&](auto* type) {
    std::remove_pointer_t<decltype(type)> msg{};
    if (!decode(msg, data, size)) return;
    out += std::to_string(log_utime);
    out += ',';
    generated::csvRow(out, msg, options);
    written = true;
  });
  return written;
}

}  // namespace fieldline::bus_dump
