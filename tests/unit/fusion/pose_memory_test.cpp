// Fusion's saved pose (pose_memory.hpp): the text keeps every bit, a file that is not a saved pose
// is refused naming the line, and a saved pose of another robot, field or run, or too old, is
// not resumed.
#include "services/fusion/pose_memory.hpp"

#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>

namespace fieldline::fusion {
namespace pose_memory_test {

SavedPose example() {
  SavedPose s;
  s.robot_id = 2;
  s.field = "msl";
  s.supervisor = "boot 1234 pid 77 started 99";
  s.saved_steady_us = 5'000'000'000;
  s.pose = {3.1, -2.0 / 3.0, 2.5};
  s.covariance << 0.01, 0.001, 0.0, 0.001, 0.02, 0.0005, 0.0, 0.0005, 0.003;
  s.twin_ambiguous = true;
  return s;
}

TEST(PoseMemory, TheTextKeepsEveryBit) {
  const SavedPose s = example();
  const SavedPose back = decodeSavedPose(encodeSavedPose(s));
  EXPECT_EQ(back.robot_id, 2);
  EXPECT_EQ(back.field, "msl");
  EXPECT_EQ(back.supervisor, s.supervisor);
  EXPECT_EQ(back.saved_steady_us, s.saved_steady_us);
  EXPECT_EQ(back.pose.y, s.pose.y);
  EXPECT_EQ(back.covariance, s.covariance);
  EXPECT_TRUE(back.twin_ambiguous);
}

TEST(PoseMemory, ACorruptFileIsRefusedNamingTheLine) {
  const std::string good = encodeSavedPose(example());
  const auto refusal = [](const std::string& text) {
    try {
      decodeSavedPose(text);
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(refusal("").find("line 1: not a saved pose"), std::string::npos);
  EXPECT_NE(refusal(good.substr(0, good.size() / 2)).find("expected 8 lines"), std::string::npos);
  // Line `index` (0-based) of the good text replaced by `line`.
  const auto with = [&good](std::size_t index, const std::string& line) {
    std::string text;
    std::size_t begin = 0;
    for (std::size_t k = 0; begin < good.size(); ++k) {
      const std::size_t end = good.find('\n', begin) + 1;
      text += k == index ? line + "\n" : good.substr(begin, end - begin);
      begin = end;
    }
    return text;
  };
  EXPECT_NE(refusal(with(5, "pose 1e999 0 0")).find("line 6:"), std::string::npos);
  EXPECT_NE(refusal(with(6, "covariance -1 0 0 1 0 1"))
                .find("line 7: covariance not finite or not positive definite"),
            std::string::npos);
  EXPECT_NE(refusal(with(1, "robot two")).find("line 2: expected 1 values"), std::string::npos);
  EXPECT_NE(refusal(with(7, "twin_ambiguous 2")).find("line 8: twin_ambiguous must be 0 or 1"),
            std::string::npos);
  EXPECT_EQ(refusal(with(1, "robot 2")), "accepted");
}

TEST(PoseMemory, OnlyARecentPoseOfTheSameRobotFieldAndRunIsResumed) {
  const SavedPose s = example();
  const std::string run = s.supervisor;
  double age = -1.0;
  EXPECT_EQ(resumeRefusal(s, 2, "msl", run, s.saved_steady_us + 800'000, 5.0, age), "");
  EXPECT_DOUBLE_EQ(age, 0.8);
  EXPECT_EQ(resumeRefusal(s, 3, "msl", run, s.saved_steady_us, 5.0, age), "resume_other_robot");
  EXPECT_EQ(resumeRefusal(s, 2, "fu2004", run, s.saved_steady_us, 5.0, age), "resume_other_field");
  EXPECT_EQ(resumeRefusal(s, 2, "msl", "boot 1234 pid 78 started 120", s.saved_steady_us, 5.0, age),
            "resume_new_run");
  EXPECT_EQ(resumeRefusal(s, 2, "msl", run, s.saved_steady_us + 5'100'000, 5.0, age),
            "resume_stale");
  EXPECT_EQ(resumeRefusal(s, 2, "msl", run, s.saved_steady_us - 1, 5.0, age), "resume_from_future");
}

TEST(PoseMemory, TheFileIsWrittenWholeAndAMissingOneIsNone) {
  const std::string path =
      testing::TempDir() + "pose_memory_test_" + std::to_string(::getpid()) + ".pose";
  std::remove(path.c_str());
  EXPECT_FALSE(readSavedPoseFile(path).has_value());
  writeSavedPoseFile(path, example());
  const auto back = readSavedPoseFile(path);
  ASSERT_TRUE(back.has_value());
  EXPECT_EQ(back->pose.x, 3.1);
  std::ofstream(path, std::ios::trunc) << "garbage\n";
  EXPECT_THROW(readSavedPoseFile(path), std::runtime_error);
  std::remove(path.c_str());
}

}  // namespace pose_memory_test
}  // namespace fieldline::fusion
