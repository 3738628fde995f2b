// A process's declared inputs and outputs (common/bus/io.hpp): the node holds its own
// subscriptions and publications to the declaration, and --print-io's YAML reads back the same.
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include "common/bus/io.hpp"
#include "common/bus/node.hpp"
#include "common/config/config.hpp"

namespace fieldline::bus {
namespace io_test {

ProcessIo lineFollower() {
  return ProcessIo("follower")
      .reads(channels::kVisionLines)
      .readsIfPresent(channels::kTeamState)
      .writes(channels::kRobotState)
      .link("serial", "/dev/tty USB0", Link::Direction::kBoth);
}

class IoTest : public ::testing::Test {
 protected:
  SimulatedClock clock{1'800'000'000'000'000};
  std::shared_ptr<Connection> memq = Connection::open("memq://");
  Node node{{.process = "follower", .robot_id = 2, .status_period_us = 0}, clock, memq};
  Node other{{.process = "other", .robot_id = 2, .status_period_us = 0}, clock, memq};
};

TEST_F(IoTest, ADeclarationMatchingTheSubscriptionsIsAccepted) {
  node.subscribe(channels::kVisionLines, [](const line_contours_t&) {});
  node.subscribe(channels::kTeamState, [](const team_state_t&) {});
  EXPECT_NO_THROW(node.declareIo(lineFollower()));
  ASSERT_TRUE(node.io().has_value());
  EXPECT_EQ(node.io()->process(), "follower");
}

TEST_F(IoTest, AnUndeclaredSubscriptionIsRefusedBeforeAndAfterTheDeclaration) {
  node.subscribe(channels::kVisionLines, [](const line_contours_t&) {});
  node.subscribe(channels::kOdometry, [](const odometry_t&) {});
  EXPECT_THROW(node.declareIo(lineFollower()), std::logic_error);

  Node declared{{.process = "follower", .robot_id = 2, .status_period_us = 0}, clock, memq};
  declared.subscribe(channels::kVisionLines, [](const line_contours_t&) {});
  declared.declareIo(lineFollower());
  EXPECT_THROW(declared.subscribe(channels::kOdometry, [](const odometry_t&) {}), std::logic_error);
  // An optional input may be subscribed later (when wanted).
  EXPECT_NO_THROW(declared.subscribe(channels::kTeamState, [](const team_state_t&) {}));
}

TEST_F(IoTest, ARequiredInputWithoutASubscriptionIsAnError) {
  node.subscribe(channels::kTeamState, [](const team_state_t&) {});
  EXPECT_THROW(node.declareIo(lineFollower()), std::logic_error);
}

TEST_F(IoTest, AnUndeclaredOutputIsNotSentAndCounted) {
  std::vector<robot_state_t> states;
  std::vector<ball_state_t> balls;
  other.subscribe(channels::kRobotState, [&](const robot_state_t& m) { states.push_back(m); });
  other.subscribe(channels::kBallState, [&](const ball_state_t& m) { balls.push_back(m); });
  node.subscribe(channels::kVisionLines, [](const line_contours_t&) {});
  node.declareIo(lineFollower());

  robot_state_t state{};
  state.header.utime = clock.now();
  EXPECT_TRUE(node.publish(channels::kRobotState, state));
  ball_state_t ball{};
  ball.header.utime = clock.now();
  EXPECT_FALSE(node.publish(channels::kBallState, ball));
  for (int i = 0; i < 5; ++i)
    other.spinOnce(0);
  EXPECT_EQ(states.size(), 1u);
  EXPECT_TRUE(balls.empty());
  EXPECT_EQ(node.status().errorCount("undeclared_output"), 1);
}

TEST(ProcessIo, PrintedYamlReadsBackTheSame) {
  const ProcessIo io = ProcessIo("viewer")
                           .readsFromEveryRobot(channels::kRobotState)
                           .readsIfPresent(channels::kSimWorld);
  const std::string printed =
      "12:00:00 info some log line\n" + std::string(kIoMarker) + "\n" + lineFollower().toYaml();
  const ProcessIo back = parseProcessIo(printed, "test");
  EXPECT_EQ(back.process(), "follower");
  ASSERT_EQ(back.inputs().size(), 2u);
  EXPECT_EQ(back.inputs()[0].channel, "VISION_LINES");
  EXPECT_TRUE(back.inputs()[0].required);
  EXPECT_FALSE(back.inputs()[1].required);
  ASSERT_EQ(back.outputs().size(), 1u);
  EXPECT_EQ(back.outputs()[0].channel, "ROBOT_STATE");
  ASSERT_EQ(back.links().size(), 1u);
  EXPECT_EQ(back.links()[0].name, "/dev/tty USB0");
  EXPECT_EQ(back.links()[0].direction, Link::Direction::kBoth);

  const ProcessIo viewer = parseProcessIo(io.toYaml(), "test");
  ASSERT_EQ(viewer.inputs().size(), 2u);
  EXPECT_TRUE(viewer.inputs()[0].every_robot);
  EXPECT_EQ(homeBus(viewer.inputs()[1].channel), BusKind::kSim);
  EXPECT_TRUE(viewer.outputs().empty());
}

TEST(ProcessIo, ADeclarationOfNoChannelOrTwiceIsRefused) {
  EXPECT_THROW(ProcessIo("x").addInput({"CAMERA_IMAGES"}), std::logic_error);
  EXPECT_THROW(ProcessIo("x").reads(channels::kOdometry).readsIfPresent(channels::kOdometry),
               std::logic_error);
  EXPECT_THROW(parseProcessIo("process: x\nreads: [{channel: ODOMETRI, bus: robot, required: "
                              "true, every_robot: false}]\nwrites: []\nlinks: []\n",
                              "test"),
               config::Error);
  EXPECT_THROW(parseProcessIo("process: x\nreads: []\nwrites: []\nlinks: []\nextra: 1\n", "test"),
               config::Error);
}

}  // namespace io_test
}  // namespace fieldline::bus
