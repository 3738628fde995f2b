// Image-to-pose latency from message stamps (tools/eval/image_to_pose.hpp).
#include <gtest/gtest.h>

#include "tools/eval/image_to_pose.hpp"

namespace fieldline::eval {
namespace {

constexpr Utime kMs = 1000;

TEST(ImageToPose, EachCorrectionCountsOnceFromItsFramesArrivalToItsFirstState) {
  ImageToPose latency;
  const Utime t0 = 1'000'000'000;
  // Frames every 33 ms, delivered 60 ms after their exposure.
  for (int k = 0; k < 10; ++k) {
    const Utime exposure = t0 + k * 33 * kMs;
    latency.onImage(1, exposure, exposure + 60 * kMs);
  }
  // States at 50 Hz from t0 + 300 ms; the correction from the frame exposed at t0 + 264 ms
  // (delivered at t0 + 324 ms) shows first in the state published at t0 + 327 ms, then again.
  const Utime frame = t0 + 8 * 33 * kMs;
  latency.onState(1, t0 + 300 * kMs, 0, t0 + 301 * kMs);  // no correction yet: not counted
  latency.onState(1, t0 + 320 * kMs, (t0 + 320 * kMs) - frame, t0 + 327 * kMs);
  latency.onState(1, t0 + 340 * kMs, (t0 + 340 * kMs) - frame, t0 + 341 * kMs);
  // A correction whose frame was never seen.
  latency.onState(1, t0 + 360 * kMs, 360 * kMs + 5, t0 + 361 * kMs);

  const auto figures = latency.figures();
  ASSERT_EQ(figures.count(1), 1u);
  const ImageToPoseFigures& f = figures.at(1);
  EXPECT_EQ(f.corrections, 1u);
  EXPECT_EQ(f.unmatched, 1u);
  EXPECT_DOUBLE_EQ(f.p50_ms, 3.0);
  EXPECT_DOUBLE_EQ(f.p99_ms, 3.0);
  EXPECT_DOUBLE_EQ(f.camera_delay_ms, 60.0);
  EXPECT_NE(latency.line().find("p99 3.0 ms beyond the camera's own 60.0 ms"), std::string::npos)
      << latency.line();
}

TEST(ImageToPose, QuantilesPerRobotAndOverTheTeam) {
  ImageToPose latency;
  const Utime t0 = 2'000'000'000;
  for (int robot = 1; robot <= 2; ++robot) {
    for (int k = 0; k < 100; ++k) {
      const Utime exposure = t0 + k * 33 * kMs;
      const Utime arrival = exposure + 60 * kMs;
      latency.onImage(robot, exposure, arrival);
      // Robot 1's states follow 1..100 ms after the frame, robot 2's always 2 ms.
      const Utime after = robot == 1 ? (k + 1) * kMs : 2 * kMs;
      const Utime state = arrival + after;
      latency.onState(robot, state, state - exposure, state);
    }
  }
  const auto figures = latency.figures();
  EXPECT_EQ(figures.at(1).corrections, 100u);
  EXPECT_NEAR(figures.at(1).p50_ms, 50.5, 1.0);
  EXPECT_NEAR(figures.at(1).p99_ms, 99.0, 1.0);
  EXPECT_DOUBLE_EQ(figures.at(1).max_ms, 100.0);
  EXPECT_DOUBLE_EQ(figures.at(2).p99_ms, 2.0);
  const ImageToPoseFigures all = latency.total();
  EXPECT_EQ(all.corrections, 200u);
  EXPECT_NEAR(all.p50_ms, 2.0, 1.0);
}

TEST(ImageToPose, TheStartIsLeftOutAndTheLineSaysSo) {
  // 2 s left out; frames every 100 ms from t0 for 4 s, each corrected 30 ms after its arrival
  // during the first second (start-up), 2 ms after it later.
  ImageToPose latency(2.0);
  const Utime t0 = 3'000'000'000;
  for (int k = 0; k < 40; ++k) {
    const Utime exposure = t0 + k * 100 * kMs;
    const Utime arrival = exposure + 60 * kMs;
    latency.onImage(1, exposure, arrival);
    const Utime state = arrival + (k < 10 ? 30 : 2) * kMs;
    latency.onState(1, state, state - exposure, state);
  }
  const ImageToPoseFigures all = latency.total();
  // Frames arriving before t0 + 60 ms + 2 s: k = 0..19.
  EXPECT_EQ(all.left_out, 20u);
  EXPECT_EQ(all.corrections, 20u);
  EXPECT_DOUBLE_EQ(all.p99_ms, 2.0);
  EXPECT_NE(latency.line().find("20 in the first 2.0 s left out"), std::string::npos)
      << latency.line();
}

TEST(ImageToPose, NothingMatchedSaysSo) {
  ImageToPose latency;
  EXPECT_EQ(latency.line(), "image-to-pose latency: no corrections matched with their frame");
}

}  // namespace
}  // namespace fieldline::eval
