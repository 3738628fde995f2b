// The viewer's playback of a recording (tools/viewer/recording_view, playback) on the lcm-logger
// recording of tests/data/recordings/main_9085e4b (robot 1 with its clock 312 ms ahead, and the
// simulator's truth): the picture at a time is the last ROBOT_STATE logged by then, ages counted
// from the playhead, the series are on the truth's time, and the controls do what they say.
#include <cmath>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "common/bus/channels.hpp"
#include "common/bus/log_file.hpp"
#include "common/config/config.hpp"
#include "tools/recording/upgrade.hpp"
#include "tools/viewer/playback.hpp"
#include "tools/viewer/recording_view.hpp"

namespace fieldline::viewer {
namespace playback_test {

const std::string kRecording = config::projectRoot() + "/tests/data/recordings/main_9085e4b";
// As fieldline-viewer --log does: older message versions are read as today's.
[[maybe_unused]] const bool kUpgradesInstalled = (recording::installLogUpgrades(), true);

// The `name` number of the first object holding `"key":` after `from` in `json`.
double numberAfter(const std::string& json, const std::string& key, std::size_t from = 0) {
  const auto at = json.find("\"" + key + "\":", from);
  if (at == std::string::npos) return std::nan("");
  return std::stod(json.substr(at + key.size() + 3));
}

TEST(RecordingView, ThePictureAtATimeIsWhatWasLoggedByThen) {
  RecordingView recording(kRecording);
  ASSERT_EQ(recording.robots().size(), 1u);
  EXPECT_EQ(recording.robots()[0].robot_id, 1);
  EXPECT_TRUE(recording.hasTruth());
  EXPECT_NEAR(recording.robots()[0].clock.error.offset_us, 312'000, 1'000);
  EXPECT_GT(recording.end() - recording.start(), 4'000'000);
  // 3 s in: the last ROBOT_STATE received by then, read from the file itself.
  const Utime t = recording.start() + 3'000'000;
  bus::LogReader log(kRecording + "/robot1.lcm", {.clock = recording.robots()[0].clock.error});
  robot_state_t m;
  bus::LogEvent e;
  robot_state_t last{};
  Utime last_log = 0;
  while (log.next(bus::channels::kRobotState, m, &e) && e.timestamp <= t) {
    last = m;
    last_log = e.timestamp;
  }
  ASSERT_GT(last_log, 0);
  const std::string doc = recording.stateJson(t);
  const auto state = doc.find("\"robot_state\":{");
  ASSERT_NE(state, std::string::npos) << doc.substr(0, 300);
  EXPECT_EQ(numberAfter(doc, "seq", state), static_cast<double>(last.header.seq));
  EXPECT_EQ(numberAfter(doc, "x", state), last.x);
  // Its age is counted from the playhead, not from today.
  EXPECT_NEAR(numberAfter(doc, "age_s", state), static_cast<double>(t - last_log) * 1e-6, 1e-6);
  EXPECT_EQ(numberAfter(doc, "utime"), static_cast<double>(t));
  // Before anything was logged there is no estimate.
  EXPECT_NE(recording.stateJson(recording.start()).find("\"robot_state\":null"), std::string::npos);
  // The error series: tracking to centimetres after the start-up.
  const std::string& series = recording.seriesJson();
  EXPECT_NE(series.find("\"error\":[["), std::string::npos);
  EXPECT_NE(series.find("\"truth\":true"), std::string::npos);
}

TEST(Playback, ControlsMoveThePlayhead) {
  RecordingView recording(kRecording);
  Playback playback(recording, {});
  EXPECT_EQ(playback.playhead(), recording.start());
  EXPECT_FALSE(playback.playing());
  playback.route("/playback.json", "t=2.5&speed=2&play");
  EXPECT_NEAR(playback.playheadSeconds(), 2.5, 1e-9);
  EXPECT_TRUE(playback.playing());
  // Playing at 2x: 0.5 s of wall time is 1 s of the recording.
  const std::string doc = playback.tick(0.5);
  EXPECT_NEAR(playback.playheadSeconds(), 3.5, 1e-6);
  EXPECT_NE(doc.find("\"playback\":{\"t_s\":3.5"), std::string::npos) << doc.substr(0, 200);
  // It stops at the end.
  playback.tick(1000.0);
  EXPECT_EQ(playback.playhead(), recording.end());
  EXPECT_FALSE(playback.playing());
  playback.route("/playback.json", "pause&t=-5");
  EXPECT_EQ(playback.playhead(), recording.start());
  // Bad controls are refused (400), unknown paths are not found (404).
  EXPECT_THROW(playback.route("/playback.json", "speed=0"), std::invalid_argument);
  EXPECT_THROW(playback.route("/playback.json", "speed=fast"), std::invalid_argument);
  EXPECT_THROW(playback.route("/playback.json", "rewind"), std::invalid_argument);
  EXPECT_FALSE(playback.route("/nothing.json", ""));
  const auto series = playback.route("/recording.json", "");
  ASSERT_TRUE(series);
  EXPECT_EQ(series->content_type, "application/json");
}

}  // namespace playback_test
}  // namespace fieldline::viewer
