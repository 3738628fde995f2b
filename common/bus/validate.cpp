#include "common/bus/validate.hpp"

#include <cmath>
#include <initializer_list>
#include <utility>
#include <vector>

#include <fmt/format.h>

namespace fieldline::bus {
namespace {

using Problem = std::optional<std::string>;

// First non-finite value among named scalars.
Problem finite(std::initializer_list<std::pair<const char*, double>> values) {
  for (const auto& [name, v] : values) {
    if (!std::isfinite(v)) return fmt::format("{} is not finite ({})", name, v);
  }
  return {};
}

template <typename T>
Problem finiteArray(const char* name, const std::vector<T>& values) {
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (!std::isfinite(static_cast<double>(values[i]))) {
      return fmt::format("{}[{}] is not finite ({})", name, i, static_cast<double>(values[i]));
    }
  }
  return {};
}

template <typename T, std::size_t N>
Problem finiteArray(const char* name, const T (&values)[N]) {
  for (std::size_t i = 0; i < N; ++i) {
    if (!std::isfinite(static_cast<double>(values[i]))) {
      return fmt::format("{}[{}] is not finite ({})", name, i, static_cast<double>(values[i]));
    }
  }
  return {};
}

// A count field and the arrays it sizes must agree, or encoding would read past the vectors.
class Sized {
 public:
  Sized(const char* count_name, std::int64_t count) : count_name_(count_name), count_(count) {}
  template <typename Vec>
  Sized& operator()(const char* name, const Vec& v) {
    if (!problem_ && (count_ < 0 || static_cast<std::int64_t>(v.size()) != count_)) {
      problem_ = fmt::format("{} = {} but {} has {} elements", count_name_, count_, name, v.size());
    }
    return *this;
  }
  Problem result() const { return problem_; }

 private:
  const char* count_name_;
  std::int64_t count_;
  Problem problem_;
};

// Runs checks in order and returns the first problem.
template <typename... Checks>
Problem firstOf(Checks&&... checks) {
  Problem p;
  ((p ? void() : void(p = checks())), ...);
  return p;
}

Problem inRange(const char* name, double v, double lo, double hi) {
  if (!(v >= lo && v <= hi)) return fmt::format("{} = {} outside [{}, {}]", name, v, lo, hi);
  return {};
}

}  // namespace

std::optional<std::string> validate(const header_t& h) {
  if (h.utime <= 0) return fmt::format("header.utime = {} is not a time", h.utime);
  if (h.seq < 0) return fmt::format("header.seq = {} is negative", h.seq);
  if (h.robot_id < 0 || h.robot_id > 99) return fmt::format("header.robot_id = {}", h.robot_id);
  return {};
}

std::optional<std::string> validate(const image_t& m) {
  if (auto p = validateImageFields(m)) return p;
  return Sized("size", m.size)("data", m.data).result();
}

std::optional<std::string> validateImageFields(const image_t& m) {
  if (auto p = validate(m.header)) return p;
  if (m.width <= 0 || m.height <= 0 || m.width > 8192 || m.height > 8192) {
    return fmt::format("image size {}x{} is not plausible", m.width, m.height);
  }
  int bytes_per_pixel = 0;
  switch (m.format) {
    case image_t::FORMAT_YUYV:
      bytes_per_pixel = 2;
      break;
    case image_t::FORMAT_BGR:
      bytes_per_pixel = 3;
      break;
    case image_t::FORMAT_GRAY:
      bytes_per_pixel = 1;
      break;
    default:
      return fmt::format("unknown image format {}", m.format);
  }
  if (m.format == image_t::FORMAT_YUYV && m.width % 2 != 0) return "YUYV image with odd width";
  if (m.stride < m.width * bytes_per_pixel) {
    return fmt::format("stride {} < width {} * {} bytes", m.stride, m.width, bytes_per_pixel);
  }
  if (static_cast<std::int64_t>(m.size) != static_cast<std::int64_t>(m.stride) * m.height) {
    return fmt::format("size {} != stride {} * height {}", m.size, m.stride, m.height);
  }
  return {};
}

std::optional<std::string> validate(const line_contours_t& m) {
  if (auto p = validate(m.header)) return p;
  return firstOf(
      [&] {
        return Sized("num_points", m.num_points)("u", m.u)("v", m.v)("x", m.x)("y", m.y).result();
      },
      [&] {
        return Sized("num_sequences", m.num_sequences)("sequence_start", m.sequence_start)(
                   "sequence_end", m.sequence_end)
            .result();
      },
      [&] { return finiteArray("u", m.u); }, [&] { return finiteArray("v", m.v); },
      [&] { return finiteArray("x", m.x); }, [&] { return finiteArray("y", m.y); },
      [&]() -> Problem {
        for (int i = 0; i < m.num_sequences; ++i) {
          const int s = m.sequence_start[i], e = m.sequence_end[i];
          if (s < 0 || e < s || e > m.num_points) {
            return fmt::format("sequence {} [{}, {}) outside {} points", i, s, e, m.num_points);
          }
        }
        return {};
      },
      [&] { return inRange("touched_fraction", m.touched_fraction, 0, 1); },
      [&] { return inRange("overlap_fraction", m.overlap_fraction, 0, 1); });
}

std::optional<std::string> validate(const ball_observation_t& m) {
  if (auto p = validate(m.header)) return p;
  return firstOf(
      [&] {
        return finite({{"u", m.u},
                       {"v", m.v},
                       {"x", m.x},
                       {"y", m.y},
                       {"sigma_radial", m.sigma_radial},
                       {"sigma_tangential", m.sigma_tangential},
                       {"confidence", m.confidence}});
      },
      [&] { return inRange("confidence", m.confidence, 0, 1); });
}

std::optional<std::string> validate(const obstacle_observations_t& m) {
  if (auto p = validate(m.header)) return p;
  return firstOf(
      [&] {
        return Sized("count", m.count)("bearing", m.bearing)("distance", m.distance)(
                   "angular_width", m.angular_width)("width", m.width)("x", m.x)("y", m.y)
            .result();
      },
      [&] { return finiteArray("bearing", m.bearing); },
      [&] { return finiteArray("distance", m.distance); },
      [&] { return finiteArray("angular_width", m.angular_width); },
      [&] { return finiteArray("width", m.width); }, [&] { return finiteArray("x", m.x); },
      [&] { return finiteArray("y", m.y); });
}

std::optional<std::string> validate(const field_features_t& m) {
  if (auto p = validate(m.header)) return p;
  return firstOf(
      [&] {
        return Sized("num_features", m.num_features)("kind", m.kind)("feature_x", m.feature_x)(
                   "feature_y", m.feature_y)("feature_phi", m.feature_phi)("quality", m.quality)
            .result();
      },
      [&] {
        return Sized("num_hypotheses", m.num_hypotheses)("hypothesis_feature",
                                                         m.hypothesis_feature)("pose_x", m.pose_x)(
                   "pose_y", m.pose_y)("pose_phi", m.pose_phi)("sigma_xy", m.sigma_xy)("sigma_phi",
                                                                                       m.sigma_phi)
            .result();
      },
      [&]() -> Problem {
        for (std::size_t i = 0; i < m.kind.size(); ++i) {
          if (m.kind[i] < field_features_t::KIND_CENTER_CIRCLE ||
              m.kind[i] > field_features_t::KIND_GOAL) {
            return fmt::format("kind[{}] = {} is not a KIND_ constant", i, m.kind[i]);
          }
        }
        return {};
      },
      [&] { return finiteArray("feature_x", m.feature_x); },
      [&] { return finiteArray("feature_y", m.feature_y); },
      [&] { return finiteArray("feature_phi", m.feature_phi); },
      [&] { return finiteArray("quality", m.quality); },
      [&] { return finiteArray("pose_x", m.pose_x); },
      [&] { return finiteArray("pose_y", m.pose_y); },
      [&] { return finiteArray("pose_phi", m.pose_phi); },
      [&] { return finiteArray("sigma_xy", m.sigma_xy); },
      [&] { return finiteArray("sigma_phi", m.sigma_phi); },
      [&]() -> Problem {
        for (int i = 0; i < m.num_hypotheses; ++i) {
          const int f = m.hypothesis_feature[i];
          if (f < 0 || f >= m.num_features) {
            return fmt::format("hypothesis {} names feature {} of {}", i, f, m.num_features);
          }
        }
        return {};
      });
}

std::optional<std::string> validate(const odometry_t& m) {
  if (auto p = validate(m.header)) return p;
  return firstOf(
      [&]() -> Problem {
        // Three or four wheels, or none from a controller that reports only its movement.
        if (m.wheel_count != 0 && m.wheel_count != 3 && m.wheel_count != 4) {
          return fmt::format("wheel_count = {} (0, 3 or 4)", m.wheel_count);
        }
        return {};
      },
      [&] { return Sized("wheel_count", m.wheel_count)("ticks", m.ticks).result(); },
      [&] {
        return Sized("wheel_count", m.wheel_count)("wheel_current", m.wheel_current).result();
      },
      [&]() -> Problem {
        if (m.wheel_count == 0 && (m.status & odometry_t::STATUS_CURRENTS) != 0) {
          return "STATUS_CURRENTS without wheels (wheel_count = 0)";
        }
        return {};
      },
      [&] {
        return finite({{"dx", m.dx},
                       {"dy", m.dy},
                       {"dphi", m.dphi},
                       {"vx", m.vx},
                       {"vy", m.vy},
                       {"omega", m.omega}});
      });
}

std::optional<std::string> validate(const motion_command_t& m) {
  if (auto p = validate(m.header)) return p;
  // Values beyond [-1, 1] are legal on the bus: the motor bridge clamps them (and counts it).
  return finite({{"vx", m.vx}, {"vy", m.vy}, {"omega", m.omega}});
}

std::optional<std::string> validate(const robot_state_t& m) {
  if (auto p = validate(m.header)) return p;
  return firstOf(
      [&] {
        return finite({{"x", m.x},
                       {"y", m.y},
                       {"phi", m.phi},
                       {"vx", m.vx},
                       {"vy", m.vy},
                       {"omega", m.omega}});
      },
      [&] { return finiteArray("covariance", m.covariance); },
      [&] {
        return inRange("status", m.status, robot_state_t::STATUS_UNKNOWN,
                       robot_state_t::STATUS_ODOMETRY_ONLY);
      });
}

std::optional<std::string> validate(const ball_state_t& m) {
  if (auto p = validate(m.header)) return p;
  return firstOf(
      [&] {
        return finite({{"x", m.x}, {"y", m.y}, {"vx", m.vx}, {"vy", m.vy}});
      },
      [&] { return finiteArray("covariance", m.covariance); });
}

std::optional<std::string> validate(const team_state_t& m) {
  if (auto p = validate(m.header)) return p;
  return firstOf([&] { return inRange("num_robots", m.num_robots, 0, 32); },
                 [&] {
                   return Sized("num_robots", m.num_robots)("present", m.present)(
                              "robot_x", m.robot_x)("robot_y", m.robot_y)("robot_phi", m.robot_phi)(
                              "robot_sigma_xy", m.robot_sigma_xy)("robot_age_us", m.robot_age_us)(
                              "ball_valid", m.ball_valid)("ball_x", m.ball_x)("ball_y", m.ball_y)(
                              "ball_age_us", m.ball_age_us)("clock_offset_us", m.clock_offset_us)(
                              "round_trip_us", m.round_trip_us)("packets_received",
                                                                m.packets_received)(
                              "packets_rejected", m.packets_rejected)("robot_twin_ambiguous",
                                                                      m.robot_twin_ambiguous)
                       .result();
                 },
                 [&] { return finiteArray("robot_x", m.robot_x); },
                 [&] { return finiteArray("robot_y", m.robot_y); },
                 [&] { return finiteArray("robot_phi", m.robot_phi); },
                 [&] { return finiteArray("robot_sigma_xy", m.robot_sigma_xy); },
                 [&] { return finiteArray("ball_x", m.ball_x); },
                 [&] { return finiteArray("ball_y", m.ball_y); },
                 [&] {
                   return finite({{"team_ball_x", m.team_ball_x},
                                  {"team_ball_y", m.team_ball_y},
                                  {"team_ball_vx", m.team_ball_vx},
                                  {"team_ball_vy", m.team_ball_vy}});
                 },
                 [&] { return finiteArray("team_ball_covariance", m.team_ball_covariance); });
}

std::optional<std::string> validate(const service_status_t& m) {
  if (auto p = validate(m.header)) return p;
  if (m.process.empty()) return "process name is empty";
  return firstOf(
      [&] {
        return Sized("num_channels", m.num_channels)("channel", m.channel)(
                   "direction", m.direction)("messages_total", m.messages_total)(
                   "rate_hz", m.rate_hz)("drops_total", m.drops_total)(
                   "rejected_total", m.rejected_total)("latency_p50_ms", m.latency_p50_ms)(
                   "latency_p95_ms", m.latency_p95_ms)("latency_max_ms", m.latency_max_ms)
            .result();
      },
      [&] {
        return Sized("num_errors", m.num_errors)("error_kind", m.error_kind)("error_count",
                                                                             m.error_count)
            .result();
      },
      [&] {
        return Sized("num_metrics", m.num_metrics)("metric_name", m.metric_name)("metric_value",
                                                                                 m.metric_value)
            .result();
      },
      [&] { return finiteArray("rate_hz", m.rate_hz); },
      [&] { return finiteArray("latency_p50_ms", m.latency_p50_ms); },
      [&] { return finiteArray("latency_p95_ms", m.latency_p95_ms); },
      [&] { return finiteArray("latency_max_ms", m.latency_max_ms); },
      [&] { return finiteArray("metric_value", m.metric_value); });
}

std::optional<std::string> validate(const world_state_t& m) {
  if (auto p = validate(m.header)) return p;
  return firstOf(
      [&] {
        return Sized("num_robots", m.num_robots)("robot_id", m.robot_id)("robot_x", m.robot_x)(
                   "robot_y", m.robot_y)("robot_phi", m.robot_phi)("robot_vx", m.robot_vx)(
                   "robot_vy", m.robot_vy)("robot_omega", m.robot_omega)("robot_kidnaps",
                                                                         m.robot_kidnaps)
            .result();
      },
      [&] {
        return Sized("num_opponents", m.num_opponents)("opponent_x", m.opponent_x)(
                   "opponent_y", m.opponent_y)("opponent_phi", m.opponent_phi)("opponent_radius",
                                                                               m.opponent_radius)
            .result();
      },
      [&]() -> Problem {
        for (std::size_t i = 0; i < m.robot_id.size(); ++i) {
          if (m.robot_id[i] < 1 || m.robot_id[i] > 99) {
            return fmt::format("robot_id[{}] = {} outside 1..99", i, m.robot_id[i]);
          }
        }
        return {};
      },
      [&] { return finiteArray("robot_x", m.robot_x); },
      [&] { return finiteArray("robot_y", m.robot_y); },
      [&] { return finiteArray("robot_phi", m.robot_phi); },
      [&] { return finiteArray("robot_vx", m.robot_vx); },
      [&] { return finiteArray("robot_vy", m.robot_vy); },
      [&] { return finiteArray("robot_omega", m.robot_omega); },
      [&] { return finiteArray("opponent_x", m.opponent_x); },
      [&] { return finiteArray("opponent_y", m.opponent_y); },
      [&] { return finiteArray("opponent_phi", m.opponent_phi); },
      [&] { return finiteArray("opponent_radius", m.opponent_radius); },
      [&] {
        return finite({{"ball_x", m.ball_x},
                       {"ball_y", m.ball_y},
                       {"ball_vx", m.ball_vx},
                       {"ball_vy", m.ball_vy},
                       {"ball_radius", m.ball_radius},
                       {"robot_radius", m.robot_radius}});
      });
}

std::optional<std::string> validate(const recording_info_t& m) {
  if (auto p = validate(m.header)) return p;
  return firstOf(
      [&] { return Sized("num_channels", m.num_channels)("channels", m.channels).result(); },
      [&]() -> Problem {
        if (m.format_version < 1) return fmt::format("format_version {} < 1", m.format_version);
        if (m.bus_robot_id < 0 || m.bus_robot_id > 99)
          return fmt::format("bus_robot_id {} outside 0..99", m.bus_robot_id);
        if (m.clock_model < recording_info_t::CLOCK_NONE ||
            m.clock_model > recording_info_t::CLOCK_ESTIMATED)
          return fmt::format("clock_model {} is not one of the CLOCK_ constants", m.clock_model);
        if (!std::isfinite(m.clock_drift_ppm) || std::fabs(m.clock_drift_ppm) > 1000.0)
          return fmt::format("clock_drift_ppm {} outside +-1000", m.clock_drift_ppm);
        // Offsets beyond an hour are no clock error but a wrong date.
        if (m.clock_offset_us < -3'600'000'000 || m.clock_offset_us > 3'600'000'000)
          return fmt::format("clock_offset_us {} beyond +-1 h", m.clock_offset_us);
        if (m.image_every < 0) return fmt::format("image_every {} < 0", m.image_every);
        if (m.file_index < 0) return fmt::format("file_index {} < 0", m.file_index);
        if (m.max_file_bytes < 0) return fmt::format("max_file_bytes {} < 0", m.max_file_bytes);
        if (m.clock_observed_messages < 0)
          return fmt::format("clock_observed_messages {} < 0", m.clock_observed_messages);
        return {};
      });
}

}  // namespace fieldline::bus
