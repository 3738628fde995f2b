// Writes the fixture log of bus_dump_test.sh with bus::LogWriter: one message of every channel
// with known field values (bus_dump_test.py holds the same values as the expected JSON), then a
// garbage event and a NaN message, which the dump must report and skip, and a good one.
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include "common/bus/log_file.hpp"

using namespace fieldline;

namespace {

constexpr Utime kBase = 1'700'000'000'000'000;

header_t header(std::int64_t seq) {
  header_t h{};
  h.utime = kBase + seq * 1000;
  h.utime_published = h.utime + 250;
  h.seq = seq;
  h.robot_id = 2;
  h.publisher_id = 0x5eed00 + seq;
  return h;
}

// Log time: 100 µs after publication.
Utime logTime(std::int64_t seq) {
  return kBase + seq * 1000 + 350;
}

}  // namespace

int main(int argc, char** argv) {
  const bool probe = argc == 3 && std::string(argv[2]) == "--probe";
  if (argc != 2 && !probe) {
    std::fprintf(stderr, "usage: %s OUTPUT.lcmlog [--probe]\n", argv[0]);
    return 2;
  }
  const std::string path = argv[1];
  if (probe) {
    // One message with seq 1000, for the live test to see that the dump is listening.
    bus::LogWriter log(path);
    motion_command_t command{};
    command.header = header(1000);
    log.write(bus::channels::kMotionCommand, logTime(1000), command);
    return 0;
  }
  {
    bus::LogWriter log(path);
    namespace ch = bus::channels;

    image_t image{};
    image.header = header(0);
    image.width = 4;
    image.height = 2;
    image.stride = 4;
    image.format = image_t::FORMAT_GRAY;
    image.source = image_t::SOURCE_LOG;
    image.frame_number = 77;
    image.exposure_us = 5000;
    image.size = 8;
    image.data = {0, 1, 2, 3, 250, 251, 252, 253};
    log.write(ch::kCameraImage, logTime(0), image);

    line_contours_t lines{};
    lines.header = header(1);
    lines.num_points = 3;
    lines.u = {10.5f, 11.5f, 12.5f};
    lines.v = {20.25f, 21.25f, 22.25f};
    lines.x = {1.0f, 1.5f, 2.0f};
    lines.y = {-0.5f, 0.0f, 0.5f};
    lines.num_sequences = 1;
    lines.sequence_start = {0};
    lines.sequence_end = {3};
    lines.image_width = 640;
    lines.image_height = 480;
    lines.cells_touched = 1234;
    lines.touched_fraction = 0.125f;
    lines.overlap_fraction = 0.75f;
    lines.initial_searches = 2;
    lines.processing_us = 4321;
    log.write(ch::kVisionLines, logTime(1), lines);

    ball_observation_t ball{};
    ball.header = header(2);
    ball.visible = 1;
    ball.u = 100.5f;
    ball.v = 200.5f;
    ball.x = 3.25f;
    ball.y = -1.75f;
    ball.sigma_radial = 0.125f;
    ball.sigma_tangential = 0.0625f;
    ball.cells = 42;
    ball.confidence = 0.875f;
    log.write(ch::kVisionBall, logTime(2), ball);

    obstacle_observations_t obstacles{};
    obstacles.header = header(3);
    obstacles.count = 2;
    obstacles.bearing = {0.5f, -1.25f};
    obstacles.distance = {2.5f, 4.0f};
    obstacles.angular_width = {0.25f, 0.125f};
    obstacles.width = {0.5f, 0.5f};
    obstacles.x = {2.0f, 1.0f};
    obstacles.y = {1.0f, -3.5f};
    log.write(ch::kVisionObstacles, logTime(3), obstacles);

    field_features_t features{};
    features.header = header(4);
    features.num_features = 2;
    features.kind = {field_features_t::KIND_CENTER_CIRCLE, field_features_t::KIND_T_JUNCTION};
    features.feature_x = {1.5f, 3.0f};
    features.feature_y = {0.25f, -2.0f};
    features.feature_phi = {0.5f, 1.5f};
    features.quality = {0.75f, 0.5f};
    features.num_hypotheses = 3;
    features.hypothesis_feature = {0, 0, 1};
    features.pose_x = {-1.5f, 1.5f, 4.0f};
    features.pose_y = {-0.25f, 0.25f, 2.0f};
    features.pose_phi = {0.0f, 3.0f, -1.0f};
    features.sigma_xy = {0.25f, 0.25f, 0.5f};
    features.sigma_phi = {0.125f, 0.125f, 0.25f};
    log.write(ch::kFieldFeatures, logTime(4), features);

    odometry_t odometry{};
    odometry.header = header(5);
    odometry.wheel_count = 4;
    odometry.ticks = {100, -200, 2147483647, -5};
    odometry.controller_utime = 9876543210;
    odometry.dx = 0.015625;
    odometry.dy = -0.0078125;
    odometry.dphi = 0.001;
    odometry.vx = 0.78125;
    odometry.vy = -0.390625;
    odometry.omega = 0.05;
    odometry.status = int{odometry_t::STATUS_FRAMES_LOST} | int{odometry_t::STATUS_RESYNC} |
                      int{odometry_t::STATUS_CURRENTS} | int{odometry_t::STATUS_GYRO};
    odometry.wheel_current = {1.25f, -0.5f, 0.0f, 0.75f};
    odometry.gyro_dphi = 0.0009765625;
    log.write(ch::kOdometry, logTime(5), odometry);

    motion_command_t command{};
    command.header = header(6);
    command.vx = 0.5;
    command.vy = -0.25;
    command.omega = 0.1;
    command.deadline_utime = kBase + 206000;
    command.source = motion_command_t::SOURCE_PILOT;
    log.write(ch::kMotionCommand, logTime(6), command);

    robot_state_t robot{};
    robot.header = header(7);
    robot.x = 1.25;
    robot.y = -2.5;
    robot.phi = 3.141592653589793;
    robot.vx = 0.5;
    robot.vy = 0.25;
    robot.omega = -0.125;
    for (int i = 0; i < 9; ++i)
      robot.covariance[i] = i % 4 == 0 ? 0.01 * (i + 1) : 0.0;
    robot.status = robot_state_t::STATUS_TRACKING;
    robot.since_vision_us = 33000;
    robot.twin_ambiguous = 1;
    log.write(ch::kRobotState, logTime(7), robot);

    ball_state_t ball_state{};
    ball_state.header = header(8);
    ball_state.valid = 0;
    ball_state.x = 4.5;
    ball_state.y = 1.5;
    ball_state.vx = -1.0;
    ball_state.vy = 0.0;
    ball_state.covariance[0] = 0.04;
    ball_state.covariance[1] = 0.001;
    ball_state.covariance[2] = 0.001;
    ball_state.covariance[3] = 0.09;
    ball_state.last_seen_utime = kBase + 7000;
    log.write(ch::kBallState, logTime(8), ball_state);

    team_state_t team{};
    team.header = header(9);
    team.num_robots = 2;
    team.present = {1, 0};
    team.robot_x = {1.0, 0.0};
    team.robot_y = {2.0, 0.0};
    team.robot_phi = {0.5, 0.0};
    team.robot_sigma_xy = {0.25f, 0.0f};
    team.robot_age_us = {12000, 0};
    team.ball_valid = {1, 0};
    team.ball_x = {3.0, 0.0};
    team.ball_y = {-1.0, 0.0};
    team.ball_age_us = {40000, 0};
    team.clock_offset_us = {-1500, 0};
    team.round_trip_us = {800, 0};
    team.packets_received = {500, 0};
    team.packets_rejected = {3, 0};
    team.robot_twin_ambiguous = {1, 0};
    team.team_ball_valid = 1;
    team.team_ball_x = 3.0;
    team.team_ball_y = -1.0;
    team.team_ball_vx = 0.5;
    team.team_ball_vy = 0.25;
    team.team_ball_covariance[0] = 0.01;
    team.team_ball_covariance[3] = 0.02;
    log.write(ch::kTeamState, logTime(9), team);

    service_status_t status{};
    status.header = header(10);
    // Quotes, a backslash, a control character, UTF-8 and a byte that is not UTF-8.
    status.process = "dump \"test\" \\ tab\t µs \xff";
    status.pid = 4242;
    status.uptime_us = 60000000;
    status.period_us = 1000000;
    status.state = service_status_t::STATE_WARN;
    status.num_channels = 1;
    status.channel = {"ODOMETRY"};
    status.direction = {service_status_t::DIRECTION_IN};
    status.messages_total = {3000};
    status.rate_hz = {50.0f};
    status.drops_total = {1};
    status.rejected_total = {2};
    status.latency_p50_ms = {1.5f};
    status.latency_p95_ms = {2.5f};
    status.latency_max_ms = {4.0f};
    status.processing_p50_ms = 0.25f;
    status.processing_p95_ms = 0.5f;
    status.processing_max_ms = 1.0f;
    status.num_errors = 1;
    status.error_kind = {"decode"};
    status.error_count = {2};
    status.last_error = "undecodable message of 3 bytes";
    status.last_error_utime = kBase + 5000;
    status.num_metrics = 1;
    status.metric_name = {"fps"};
    status.metric_value = {30.0};
    status.state_reason = "ODOMETRY silent 2.1 s";
    log.write(ch::kServiceStatus, logTime(10), status);

    world_state_t world{};
    world.header = header(11);
    world.header.robot_id = 0;
    world.field = "msl";
    world.scenario = "kidnap";
    world.num_robots = 1;
    world.robot_id = {2};
    world.robot_x = {1.0};
    world.robot_y = {-1.0};
    world.robot_phi = {0.5};
    world.robot_vx = {0.25};
    world.robot_vy = {0.0};
    world.robot_omega = {0.125};
    world.robot_kidnaps = {1};
    world.robot_radius = 0.25f;
    world.num_opponents = 1;
    world.opponent_x = {5.0};
    world.opponent_y = {2.0};
    world.opponent_phi = {3.0};
    world.opponent_radius = {0.25f};
    world.ball_x = 0.5;
    world.ball_y = 0.75;
    world.ball_vx = 0.0;
    world.ball_vy = -0.5;
    world.ball_radius = 0.11f;
    log.write(ch::kSimWorld, logTime(11), world);

    // Bad events: garbage on ODOMETRY, and a robot state with a NaN position.
    const unsigned char garbage[] = {0xde, 0xad, 0xbe, 0xef, 0x01};
    log.write(ch::kOdometry.name, logTime(12), garbage, sizeof garbage);
    robot.header = header(13);
    robot.x = std::numeric_limits<double>::quiet_NaN();
    log.write(ch::kRobotState, logTime(13), robot);
    // A good message after the bad ones: the dump goes on.
    odometry.header = header(14);
    log.write(ch::kOdometry, logTime(14), odometry);
  }
  return 0;
}
