#include "tools/bus_dump/message_json.hpp"

#include <cmath>
#include <concepts>
#include <cstddef>
#include <exception>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "common/bus/channels.hpp"
#include "tools/json/json_text.hpp"

namespace fieldline::bus_dump {
namespace {

void appendValue(std::string& out, std::int8_t v) {
  out += std::to_string(int{v});
}
void appendValue(std::string& out, std::uint8_t v) {
  out += std::to_string(unsigned{v});
}
void appendValue(std::string& out, std::int32_t v) {
  out += std::to_string(v);
}
void appendValue(std::string& out, std::int64_t v) {
  out += std::to_string(v);
}
// Validated messages have no NaN or infinity, but a writer must not emit invalid JSON if one
// slips through: json::appendNumber writes null.
void appendValue(std::string& out, float v) {
  json::appendNumber(out, v);
}
void appendValue(std::string& out, double v) {
  json::appendNumber(out, v);
}
void appendValue(std::string& out, const std::string& v) {
  json::appendString(out, v);
}

template <typename T>
void appendArray(std::string& out, const T* values, std::size_t count) {
  out += '[';
  for (std::size_t i = 0; i < count; ++i) {
    if (i > 0) out += ',';
    appendValue(out, values[i]);
  }
  out += ']';
}

// An object under construction with one adder per LCM field type.
class Object {
 public:
  explicit Object(std::string& out) : object_(out) {}

  std::string& key(std::string_view name) { return object_.key(name); }
  template <typename T>
  Object& add(std::string_view name, const T& value) {
    appendValue(key(name), value);
    return *this;
  }
  // LCM's boolean is an int8_t in C++; JSON gets true/false.
  Object& addBool(std::string_view name, std::int8_t value) {
    key(name) += value ? "true" : "false";
    return *this;
  }
  template <typename T>
  Object& addArray(std::string_view name, const std::vector<T>& values) {
    appendArray(key(name), values.data(), values.size());
    return *this;
  }
  template <typename T, std::size_t N>
  Object& addArray(std::string_view name, const T (&values)[N]) {
    appendArray(key(name), values, N);
    return *this;
  }
  Object& addBoolArray(std::string_view name, const std::vector<std::int8_t>& values) {
    std::string& out = key(name);
    out += '[';
    for (std::size_t i = 0; i < values.size(); ++i) {
      if (i > 0) out += ',';
      out += values[i] ? "true" : "false";
    }
    out += ']';
    return *this;
  }

 private:
  json::Object object_;
};

// ---- one writer per message type (fields in the order of lcmtypes/*.lcm) --------------------

void write(std::string& out, const header_t& m, const JsonOptions&) {
  Object o(out);
  o.add("utime", m.utime).add("utime_published", m.utime_published).add("seq", m.seq);
  o.add("robot_id", m.robot_id);
}

void addHeader(Object& o, const header_t& header, const JsonOptions& options) {
  write(o.key("header"), header, options);
}

void write(std::string& out, const image_t& m, const JsonOptions& options) {
  Object o(out);
  addHeader(o, m.header, options);
  o.add("width", m.width).add("height", m.height).add("stride", m.stride);
  o.add("format", m.format).add("source", m.source).add("frame_number", m.frame_number);
  o.add("exposure_us", m.exposure_us).add("size", m.size);
  if (options.image_data) {
    o.addArray("data", m.data);
  } else {
    // Pixels would swamp the output; the hash says whether two frames are the same.
    o.key("data_fnv1a64") += fmt::format("\"{:016x}\"", fnv1a64(m.data.data(), m.data.size()));
  }
}

void write(std::string& out, const line_contours_t& m, const JsonOptions& options) {
  Object o(out);
  addHeader(o, m.header, options);
  o.add("num_points", m.num_points);
  o.addArray("u", m.u).addArray("v", m.v).addArray("x", m.x).addArray("y", m.y);
  o.add("num_sequences", m.num_sequences);
  o.addArray("sequence_start", m.sequence_start).addArray("sequence_end", m.sequence_end);
  o.add("image_width", m.image_width).add("image_height", m.image_height);
  o.add("cells_touched", m.cells_touched).add("touched_fraction", m.touched_fraction);
  o.add("overlap_fraction", m.overlap_fraction).add("initial_searches", m.initial_searches);
  o.add("processing_us", m.processing_us);
}

void write(std::string& out, const ball_observation_t& m, const JsonOptions& options) {
  Object o(out);
  addHeader(o, m.header, options);
  o.addBool("visible", m.visible);
  o.add("u", m.u).add("v", m.v).add("x", m.x).add("y", m.y);
  o.add("sigma_radial", m.sigma_radial).add("sigma_tangential", m.sigma_tangential);
  o.add("cells", m.cells).add("confidence", m.confidence);
}

void write(std::string& out, const obstacle_observations_t& m, const JsonOptions& options) {
  Object o(out);
  addHeader(o, m.header, options);
  o.add("count", m.count);
  o.addArray("bearing", m.bearing).addArray("distance", m.distance);
  o.addArray("angular_width", m.angular_width).addArray("width", m.width);
  o.addArray("x", m.x).addArray("y", m.y);
}

void write(std::string& out, const field_features_t& m, const JsonOptions& options) {
  Object o(out);
  addHeader(o, m.header, options);
  o.add("num_features", m.num_features);
  o.addArray("kind", m.kind).addArray("feature_x", m.feature_x);
  o.addArray("feature_y", m.feature_y).addArray("feature_phi", m.feature_phi);
  o.addArray("quality", m.quality);
  o.add("num_hypotheses", m.num_hypotheses);
  o.addArray("hypothesis_feature", m.hypothesis_feature);
  o.addArray("pose_x", m.pose_x).addArray("pose_y", m.pose_y).addArray("pose_phi", m.pose_phi);
  o.addArray("sigma_xy", m.sigma_xy).addArray("sigma_phi", m.sigma_phi);
}

void write(std::string& out, const odometry_t& m, const JsonOptions& options) {
  Object o(out);
  addHeader(o, m.header, options);
  o.add("wheel_count", m.wheel_count);
  o.addArray("ticks", m.ticks).add("controller_utime", m.controller_utime);
  o.add("dx", m.dx).add("dy", m.dy).add("dphi", m.dphi);
  o.add("vx", m.vx).add("vy", m.vy).add("omega", m.omega).add("status", m.status);
  o.addArray("wheel_current", m.wheel_current).add("gyro_dphi", m.gyro_dphi);
}

void write(std::string& out, const motion_command_t& m, const JsonOptions& options) {
  Object o(out);
  addHeader(o, m.header, options);
  o.add("vx", m.vx).add("vy", m.vy).add("omega", m.omega);
  o.add("deadline_utime", m.deadline_utime).add("source", m.source);
}

void write(std::string& out, const robot_state_t& m, const JsonOptions& options) {
  Object o(out);
  addHeader(o, m.header, options);
  o.add("x", m.x).add("y", m.y).add("phi", m.phi);
  o.add("vx", m.vx).add("vy", m.vy).add("omega", m.omega);
  o.addArray("covariance", m.covariance).add("status", m.status);
  o.add("since_vision_us", m.since_vision_us);
  o.addBool("twin_ambiguous", m.twin_ambiguous);
}

void write(std::string& out, const ball_state_t& m, const JsonOptions& options) {
  Object o(out);
  addHeader(o, m.header, options);
  o.addBool("valid", m.valid);
  o.add("x", m.x).add("y", m.y).add("vx", m.vx).add("vy", m.vy);
  o.addArray("covariance", m.covariance).add("last_seen_utime", m.last_seen_utime);
}

void write(std::string& out, const team_state_t& m, const JsonOptions& options) {
  Object o(out);
  addHeader(o, m.header, options);
  o.add("num_robots", m.num_robots).addBoolArray("present", m.present);
  o.addArray("robot_x", m.robot_x).addArray("robot_y", m.robot_y);
  o.addArray("robot_phi", m.robot_phi).addArray("robot_sigma_xy", m.robot_sigma_xy);
  o.addArray("robot_age_us", m.robot_age_us).addBoolArray("ball_valid", m.ball_valid);
  o.addArray("ball_x", m.ball_x).addArray("ball_y", m.ball_y);
  o.addArray("ball_age_us", m.ball_age_us).addArray("clock_offset_us", m.clock_offset_us);
  o.addArray("round_trip_us", m.round_trip_us);
  o.addArray("packets_received", m.packets_received);
  o.addArray("packets_rejected", m.packets_rejected);
  o.addBoolArray("robot_twin_ambiguous", m.robot_twin_ambiguous);
  o.addBool("team_ball_valid", m.team_ball_valid);
  o.add("team_ball_x", m.team_ball_x).add("team_ball_y", m.team_ball_y);
  o.add("team_ball_vx", m.team_ball_vx).add("team_ball_vy", m.team_ball_vy);
  o.addArray("team_ball_covariance", m.team_ball_covariance);
}

void write(std::string& out, const service_status_t& m, const JsonOptions& options) {
  Object o(out);
  addHeader(o, m.header, options);
  o.add("process", m.process).add("pid", m.pid).add("uptime_us", m.uptime_us);
  o.add("period_us", m.period_us).add("state", m.state);
  o.add("num_channels", m.num_channels).addArray("channel", m.channel);
  o.addArray("direction", m.direction).addArray("messages_total", m.messages_total);
  o.addArray("rate_hz", m.rate_hz).addArray("drops_total", m.drops_total);
  o.addArray("rejected_total", m.rejected_total);
  o.addArray("latency_p50_ms", m.latency_p50_ms).addArray("latency_p95_ms", m.latency_p95_ms);
  o.addArray("latency_max_ms", m.latency_max_ms);
  o.add("processing_p50_ms", m.processing_p50_ms).add("processing_p95_ms", m.processing_p95_ms);
  o.add("processing_max_ms", m.processing_max_ms);
  o.add("num_errors", m.num_errors).addArray("error_kind", m.error_kind);
  o.addArray("error_count", m.error_count);
  o.add("last_error", m.last_error).add("last_error_utime", m.last_error_utime);
  o.add("num_metrics", m.num_metrics).addArray("metric_name", m.metric_name);
  o.addArray("metric_value", m.metric_value);
}

void write(std::string& out, const world_state_t& m, const JsonOptions& options) {
  Object o(out);
  addHeader(o, m.header, options);
  o.add("field", m.field).add("scenario", m.scenario);
  o.add("num_robots", m.num_robots).addArray("robot_id", m.robot_id);
  o.addArray("robot_x", m.robot_x).addArray("robot_y", m.robot_y);
  o.addArray("robot_phi", m.robot_phi).addArray("robot_vx", m.robot_vx);
  o.addArray("robot_vy", m.robot_vy).addArray("robot_omega", m.robot_omega);
  o.addArray("robot_kidnaps", m.robot_kidnaps).add("robot_radius", m.robot_radius);
  o.add("num_opponents", m.num_opponents);
  o.addArray("opponent_x", m.opponent_x).addArray("opponent_y", m.opponent_y);
  o.addArray("opponent_phi", m.opponent_phi).addArray("opponent_radius", m.opponent_radius);
  o.add("ball_x", m.ball_x).add("ball_y", m.ball_y);
  o.add("ball_vx", m.ball_vx).add("ball_vy", m.ball_vy).add("ball_radius", m.ball_radius);
}

template <typename Msg>
bool decodeAndWrite(std::string& out, const void* data, int size, const JsonOptions& options) {
  Msg msg{};
  try {
    if (msg.decode(data, 0, size) != size) return false;
  } catch (const std::exception&) {
    return false;
  }
  write(out, msg, options);
  return true;
}

constexpr auto kChannels = std::make_tuple(
    bus::channels::kCameraImage, bus::channels::kVisionLines, bus::channels::kVisionBall,
    bus::channels::kVisionObstacles, bus::channels::kFieldFeatures, bus::channels::kOdometry,
    bus::channels::kMotionCommand, bus::channels::kRobotState, bus::channels::kBallState,
    bus::channels::kTeamState, bus::channels::kServiceStatus, bus::channels::kSimWorld);
static_assert(std::tuple_size_v<decltype(kChannels)> == bus::kAllChannelNames.size(),
              "every channel of channels.hpp needs a JSON writer");

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
  bool known = false;
  bool written = false;
  std::apply(
      [&](const auto&... c) {
        ((!known && c.name == channel
              ? void((known = true,
                      written = decodeAndWrite<typename std::remove_cvref_t<decltype(c)>::Message>(
                          out, data, size, options)))
              : void()),
         ...);
      },
      kChannels);
  return written;
}

}  // namespace fieldline::bus_dump
