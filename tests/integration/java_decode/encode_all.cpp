// Writes one encoded instance of every fieldline type, with distinctive values in every field
// the test knows about, to DIR/<type>.bin. DecodeCheck.java decodes them with the Java classes
// lcm-spy uses and re-encodes them: equal bytes prove both sides agree on every field.
#include <cstdint>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include "common/bus/channels.hpp"

using namespace fieldline;

namespace {

header_t header(int k) {
  header_t h{};
  h.utime = 1'700'000'000'000'000 + k;
  h.utime_published = h.utime + 60'000;
  h.seq = 40 + k;
  h.robot_id = static_cast<std::int8_t>(k % 7);
  h.publisher_id = 0x5eed0000 + k;
  return h;
}

template <typename Msg>
bool write(const std::string& dir, const std::string& name, const Msg& m) {
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(m.getEncodedSize()));
  if (m.encode(buf.data(), 0, static_cast<int>(buf.size())) != static_cast<int>(buf.size())) {
    std::cerr << "encode failed: " << name << "\n";
    return false;
  }
  std::ofstream(dir + "/" + name + ".bin", std::ios::binary)
      .write(reinterpret_cast<const char*>(buf.data()), static_cast<std::streamsize>(buf.size()));
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: encode_all DIR\n";
    return 2;
  }
  const std::string dir = argv[1];
  bool ok = true;

  ok &= write(dir, "header_t", header(1));

  image_t img{};
  img.header = header(2);
  img.width = 4;
  img.height = 2;
  img.stride = 8;
  img.format = image_t::FORMAT_YUYV;
  img.source = image_t::SOURCE_SIM;
  img.frame_number = 123456789;
  img.exposure_us = 2000;
  img.size = 16;
  for (int i = 0; i < 16; ++i)
    img.data.push_back(static_cast<std::uint8_t>(i * 13));
  ok &= write(dir, "image_t", img);

  line_contours_t lc{};
  lc.header = header(3);
  lc.num_points = 3;
  lc.u = {1.5f, 2.5f, 3.5f};
  lc.v = {4.5f, 5.5f, 6.5f};
  lc.x = {0.25f, -0.5f, 1.75f};
  lc.y = {-1.25f, 2.0f, 0.125f};
  lc.num_sequences = 2;
  lc.sequence_start = {0, 2};
  lc.sequence_end = {2, 3};
  lc.image_width = 320;
  lc.image_height = 240;
  lc.cells_touched = 777;
  lc.touched_fraction = 0.08f;
  lc.overlap_fraction = 0.9f;
  lc.initial_searches = 2;
  lc.processing_us = 1234;
  ok &= write(dir, "line_contours_t", lc);

  ball_observation_t bo{};
  bo.header = header(4);
  bo.visible = true;
  bo.u = 100.5f;
  bo.v = 80.25f;
  bo.x = 2.5f;
  bo.y = -0.75f;
  bo.sigma_radial = 0.1f;
  bo.sigma_tangential = 0.05f;
  bo.cells = 42;
  bo.confidence = 0.875f;
  ok &= write(dir, "ball_observation_t", bo);

  obstacle_observations_t ob{};
  ob.header = header(5);
  ob.count = 2;
  ob.bearing = {0.5f, -1.0f};
  ob.distance = {1.5f, 3.0f};
  ob.angular_width = {0.3f, 0.15f};
  ob.width = {0.5f, 0.45f};
  ob.x = {1.3f, 1.6f};
  ob.y = {0.7f, -2.5f};
  ok &= write(dir, "obstacle_observations_t", ob);

  field_features_t ff{};
  ff.header = header(6);
  ff.num_features = 2;
  ff.kind = {field_features_t::KIND_CENTER_CIRCLE, field_features_t::KIND_PENALTY_CORNER};
  ff.feature_x = {1.0f, 2.0f};
  ff.feature_y = {-1.0f, 0.5f};
  ff.feature_phi = {0.1f, 3.0f};
  ff.quality = {0.9f, 0.6f};
  ff.num_hypotheses = 3;
  ff.hypothesis_feature = {0, 0, 1};
  ff.pose_x = {-1.0f, 1.0f, 7.0f};
  ff.pose_y = {1.0f, -1.0f, 2.0f};
  ff.pose_phi = {0.5f, -2.6f, 1.0f};
  ff.sigma_xy = {0.05f, 0.05f, 0.1f};
  ff.sigma_phi = {0.02f, 0.02f, 0.05f};
  ok &= write(dir, "field_features_t", ff);

  odometry_t od{};
  od.header = header(7);
  // Four wheels: the arrays are sized by wheel_count.
  od.wheel_count = 4;
  od.ticks = {1000, -2000, 2147483000, -7};
  od.wheel_current = {1.5f, -0.25f, 0.0f, 2.0f};
  od.controller_utime = 987654321;
  od.dx = 0.01;
  od.dy = -0.002;
  od.dphi = 0.003;
  od.vx = 0.5;
  od.vy = -0.1;
  od.omega = 0.15;
  od.status = static_cast<std::int32_t>(odometry_t::STATUS_RESYNC) + odometry_t::STATUS_FRAMES_LOST;
  ok &= write(dir, "odometry_t", od);

  motion_command_t mc{};
  mc.header = header(8);
  mc.vx = 0.5;
  mc.vy = -0.25;
  mc.omega = 1.0;
  mc.deadline_utime = mc.header.utime + 100'000;
  mc.source = motion_command_t::SOURCE_MANUAL;
  ok &= write(dir, "motion_command_t", mc);

  robot_state_t rs{};
  rs.header = header(9);
  rs.x = 1.5;
  rs.y = -2.5;
  rs.phi = 3.0;
  rs.vx = 0.1;
  rs.vy = 0.2;
  rs.omega = -0.3;
  for (int i = 0; i < 9; ++i)
    rs.covariance[i] = 0.001 * (i + 1);
  rs.status = robot_state_t::STATUS_TRACKING;
  rs.since_vision_us = 33'000;
  rs.twin_ambiguous = 1;
  ok &= write(dir, "robot_state_t", rs);

  ball_state_t bs{};
  bs.header = header(10);
  bs.valid = true;
  bs.x = 3.0;
  bs.y = 1.0;
  bs.vx = -2.0;
  bs.vy = 0.5;
  for (int i = 0; i < 4; ++i)
    bs.covariance[i] = 0.01 * (i + 1);
  bs.last_seen_utime = bs.header.utime - 5000;
  ok &= write(dir, "ball_state_t", bs);

  team_state_t ts{};
  ts.header = header(11);
  ts.num_robots = 2;
  ts.present = {true, false};
  ts.robot_x = {1.0, 2.0};
  ts.robot_y = {-1.0, -2.0};
  ts.robot_phi = {0.1, 0.2};
  ts.robot_sigma_xy = {0.05f, 0.5f};
  ts.robot_age_us = {1000, 900000};
  ts.ball_valid = {true, false};
  ts.ball_x = {3.0, 0.0};
  ts.ball_y = {0.5, 0.0};
  ts.ball_age_us = {2000, 0};
  ts.clock_offset_us = {-1500, 250};
  ts.round_trip_us = {800, 1200};
  ts.packets_received = {500, 3};
  ts.packets_rejected = {1, 2};
  ts.robot_twin_ambiguous = {false, true};
  ts.team_ball_valid = true;
  ts.team_ball_x = 3.1;
  ts.team_ball_y = 0.4;
  ts.team_ball_vx = 0.2;
  ts.team_ball_vy = -0.2;
  for (int i = 0; i < 4; ++i)
    ts.team_ball_covariance[i] = 0.02 * (i + 1);
  ok &= write(dir, "team_state_t", ts);

  service_status_t ss{};
  ss.header = header(12);
  ss.process = "region_tracking";
  ss.pid = 4242;
  ss.uptime_us = 5'000'000;
  ss.period_us = 1'000'000;
  ss.state = service_status_t::STATE_WARN;
  ss.num_channels = 2;
  ss.channel = {"CAMERA_IMAGE", "VISION_LINES"};
  ss.direction = {service_status_t::DIRECTION_IN, service_status_t::DIRECTION_OUT};
  ss.messages_total = {300, 100};
  ss.rate_hz = {30.0f, 10.0f};
  ss.drops_total = {2, 0};
  ss.rejected_total = {1, 0};
  ss.latency_p50_ms = {60.5f, 65.0f};
  ss.latency_p95_ms = {62.0f, 70.0f};
  ss.latency_max_ms = {80.0f, 90.0f};
  ss.processing_p50_ms = 1.5f;
  ss.processing_p95_ms = 2.5f;
  ss.processing_max_ms = 4.0f;
  ss.num_errors = 1;
  ss.error_kind = {"decode"};
  ss.error_count = {1};
  ss.last_error = "CAMERA_IMAGE: undecodable message of 12 bytes";
  ss.last_error_utime = ss.header.utime - 1;
  ss.num_metrics = 1;
  ss.metric_name = {"touched_fraction"};
  ss.metric_value = {0.08};
  ok &= write(dir, "service_status_t", ss);

  world_state_t ws{};
  ws.header = header(13);
  ws.field = "msl";
  ws.scenario = "figure_eight";
  ws.num_robots = 2;
  ws.robot_id = {1, 2};
  ws.robot_x = {1.0, -1.0};
  ws.robot_y = {0.5, -0.5};
  ws.robot_phi = {0.0, 3.1};
  ws.robot_vx = {0.8, 0.0};
  ws.robot_vy = {0.0, 0.1};
  ws.robot_omega = {0.2, 0.0};
  ws.robot_kidnaps = {0, 1};
  ws.num_opponents = 1;
  ws.opponent_x = {4.0};
  ws.opponent_y = {2.0};
  ws.opponent_phi = {1.0};
  ws.opponent_radius = {0.25f};
  ws.ball_x = 0.5;
  ws.ball_y = 0.25;
  ws.ball_vx = 1.0;
  ws.ball_vy = -1.0;
  ws.ball_radius = 0.11f;
  ok &= write(dir, "world_state_t", ws);

  recording_info_t ri{};
  ri.header = header(14);
  ri.format_version = recording_info_t::FORMAT_VERSION;
  ri.bus_robot_id = 2;
  ri.clock_model = recording_info_t::CLOCK_CONFIGURED;
  ri.clock_offset_us = -447000;
  ri.clock_drift_ppm = -21.0;
  ri.clock_reference_us = 1'700'000'000'000'000;
  ri.clock_observed_offset_us = -446900;
  ri.clock_observed_messages = 1500;
  ri.host = "laptop";
  ri.version = "v0.1-12-gabcdef";
  ri.field_name = "msl";
  ri.field_yaml = "length: 22.0";
  ri.settings_yaml = "launch_file: sim_team.yaml";
  ri.num_channels = 2;
  ri.channels = {"ODOMETRY", "ROBOT_STATE"};
  ri.image_every = 10;
  ri.file_index = 3;
  ri.max_file_bytes = 500 << 20;
  ok &= write(dir, "recording_info_t", ri);

  std::cout << (ok ? "wrote 13 types to " : "FAILED writing to ") << dir << "\n";
  return ok ? 0 : 1;
}
