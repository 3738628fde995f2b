// One bus into a recording's files (tools/recording/bus_recording.hpp): every file starts with the
// recording's description, a size limit splits the recording into parts (the oldest deleted
// beyond --max-files), camera images are decimated, bad messages are refused and counted; and the
// old message versions are upgraded as a log is read (upgrade.hpp).
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <unistd.h>
#include <fieldline_legacy/odometry_v1_t.hpp>

#include "common/bus/channels.hpp"
#include "common/bus/log_file.hpp"
#include "common/bus/validate.hpp"
#include "common/config/config.hpp"
#include "tools/recording/bus_recording.hpp"
#include "tools/recording/recording_info.hpp"
#include "tools/recording/upgrade.hpp"

namespace fieldline::recording {
namespace bus_recording_test {

constexpr Utime kStart = 1'796'000'000'000'000;
// Robot 2's clock runs 447 ms behind the recorder's.
const ClockError kClock{-447'000, -21.0, kStart};

std::string tempDir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("fieldline_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  return dir.string();
}

recording_info_t info() {
  recording_info_t i{};
  i.bus_robot_id = 2;
  i.clock_model = recording_info_t::CLOCK_CONFIGURED;
  i.clock_offset_us = kClock.offset_us;
  i.clock_drift_ppm = kClock.drift_ppm;
  i.clock_reference_us = kClock.reference_us;
  i.version = "test";
  i.field_name = "msl";
  i.settings_yaml = "fusion_config_name: default\nfusion_config: |\n  ball:\n    rate_hz: 10.0\n";
  return i;
}

template <typename Msg>
std::vector<std::uint8_t> encode(const Msg& m) {
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

// ODOMETRY of robot 2 received at `log` (the recorder's clock), stamped on the robot's.
std::vector<std::uint8_t> odometry(Utime log, std::int64_t seq) {
  odometry_t m{};
  m.header.utime_published = truthToOwn(kClock, log) - 200;
  m.header.utime = m.header.utime_published - 8000;
  m.header.seq = seq;
  m.header.robot_id = 2;
  m.wheel_count = 3;
  m.ticks = {1, 2, 3};
  m.wheel_current = {0.0f, 0.0f, 0.0f};
  return encode(m);
}

TEST(BusRecording, EveryFileDescribesItselfAndTheRecordingSplitsBySize) {
  const std::string dir = tempDir("bus_recording");
  BusRecording rec(dir, "robot2", info(), {.max_file_bytes = 20'000, .max_files = 3});
  rec.writeInfo(kStart);
  for (int k = 0; k < 500; ++k) {
    const Utime t = kStart + k * 20'000;
    const auto bytes = odometry(t, k);
    rec.write(bus::channels::kOdometry.name, t, bytes.data(), static_cast<int>(bytes.size()));
  }
  rec.flush();
  EXPECT_EQ(rec.eventsWritten(), 500);
  EXPECT_GT(rec.filesStarted(), 4);
  // The oldest parts were deleted: three files are left, the newest ones.
  std::vector<std::string> files;
  for (const auto& e : std::filesystem::directory_iterator(dir))
    files.push_back(e.path().filename().string());
  EXPECT_EQ(files.size(), 3u);
  EXPECT_FALSE(std::filesystem::exists(dir + "/robot2.lcm"));
  EXPECT_TRUE(std::filesystem::exists(dir + "/" + partFileName("robot2", rec.filesStarted() - 1)));
  EXPECT_EQ(partFileName("robot2", 1), "robot2_part002.lcm");
  for (const auto& name : files) {
    const std::string path = dir + "/" + name;
    EXPECT_LE(std::filesystem::file_size(path), 20'000u);
    // Each file's first event is its description, with the robot's clock and the part's index.
    bus::LogReader log(path);
    bus::LogEvent first;
    ASSERT_TRUE(log.nextEvent(first));
    EXPECT_EQ(first.channel, bus::channels::kRecordingInfo.name);
    const auto described = readRecordingInfo(path);
    ASSERT_TRUE(described) << path;
    EXPECT_EQ(described->bus_robot_id, 2);
    EXPECT_EQ(described->clock_offset_us, -447'000);
    EXPECT_GT(described->file_index, 0);
    EXPECT_EQ(described->max_file_bytes, 20'000);
    // The reader checks every event against the log time on that clock: nothing is refused.
    const RobotClockModel clock = clockOfLog(path, 2);
    EXPECT_EQ(clock.source, ClockSource::kRecorded);
    bus::LogReader checked(path, {.clock = clock.error});
    bus::LogEvent e;
    int n = 0;
    while (checked.nextChecked(e))
      ++n;
    EXPECT_GT(n, 10);
    EXPECT_EQ(checked.rejectedTotal(), 0) << path;
  }
  // The clock check: fitted to the traffic, the recorded clock is what the robot stamped with.
  ASSERT_TRUE(rec.observedClock());
  EXPECT_NEAR(static_cast<double>(rec.observedClock()->ownAt(kStart + 9'000'000) -
                                  truthToOwn(kClock, kStart + 9'000'000)),
              -200.0, 1000.0);
  std::filesystem::remove_all(dir);
}

TEST(BusRecording, ImagesAreDecimatedAndBadMessagesRefused) {
  const std::string dir = tempDir("bus_recording_images");
  BusRecording rec(dir, "robot2", info(), {.image_every = 3});
  image_t image{};
  image.header.robot_id = 2;
  image.header.publisher_id = 77;
  image.width = image.height = image.stride = 2;
  image.format = image_t::FORMAT_GRAY;
  image.size = 4;
  image.data = {1, 2, 3, 4};
  for (int k = 0; k < 9; ++k) {
    const Utime t = kStart + k * 33'000;
    image.header.utime = image.header.utime_published = truthToOwn(kClock, t);
    image.header.seq = k;
    const auto bytes = encode(image);
    rec.write(bus::channels::kCameraImage.name, t, bytes.data(), static_cast<int>(bytes.size()));
  }
  EXPECT_EQ(rec.eventsWritten(), 3);
  EXPECT_EQ(rec.imagesSkipped(), 6);
  // From the future of the robot's clock, and bytes that are no message: counted, not written.
  odometry_t future{};
  future.header.robot_id = 2;
  future.header.utime = future.header.utime_published = truthToOwn(kClock, kStart) + 2'000'000;
  const auto bytes = encode(future);
  rec.write(bus::channels::kOdometry.name, kStart, bytes.data(), static_cast<int>(bytes.size()));
  const std::uint8_t garbage[] = {1, 2, 3};
  rec.write(bus::channels::kOdometry.name, kStart, garbage, 3);
  EXPECT_EQ(rec.eventsWritten(), 3);
  EXPECT_EQ(rec.refused().at("future_utime"), 1);
  EXPECT_EQ(rec.refused().at("decode"), 1);
  // Without images the camera is not recorded at all.
  BusRecording none(dir + "/none", "robot2", info(), {});
  const auto frame = encode(image);
  none.write(bus::channels::kCameraImage.name, kStart, frame.data(),
             static_cast<int>(frame.size()));
  EXPECT_EQ(none.eventsWritten(), 0);
  std::filesystem::remove_all(dir);
}

TEST(RecordingInfo, SettingsOfTheLaunchFile) {
  const LaunchSettings s = settingsFromLaunchFile(config::resolvePreset("launch", "sim_team"));
  EXPECT_EQ(s.field_name, "msl");
  EXPECT_NE(s.field_yaml.find("length"), std::string::npos);
  EXPECT_EQ(settingsValue(s.settings_yaml, "fusion_config_name"), "default");
  EXPECT_NE(settingsValue(s.settings_yaml, "launch").find("fieldline-fusion"), std::string::npos);
  EXPECT_FALSE(settingsValue(s.settings_yaml, "fusion_config").empty());
  EXPECT_EQ(settingsValue(s.settings_yaml, "nothing"), "");
  EXPECT_THROW(settingsFromLaunchFile("/no/such/launch.yaml"), config::Error);
  EXPECT_NE(buildVersion(), "");
}

TEST(Upgrade, AnOldRobotStateBecomesTodaysWithItsValues) {
  // The recording of main at 428ac34 holds ROBOT_STATE without twin_ambiguous.
  bus::LogReader raw(config::projectRoot() + "/tests/data/recordings/main_428ac34/robot1.lcm");
  bus::LogEvent e;
  while (raw.nextEvent(e) && e.channel != bus::channels::kRobotState.name) {
  }
  ASSERT_EQ(e.channel, bus::channels::kRobotState.name);
  robot_state_t today{};
  EXPECT_NE(today.decode(e.data.data(), 0, static_cast<int>(e.data.size())),
            static_cast<int>(e.data.size()));  // the old bytes do not decode as today's
  const auto applied = upgradeEvent(e);
  ASSERT_TRUE(applied);
  EXPECT_EQ(*applied, "robot_state_t v1");
  ASSERT_EQ(today.decode(e.data.data(), 0, static_cast<int>(e.data.size())),
            static_cast<int>(e.data.size()));
  EXPECT_EQ(today.header.robot_id, 1);
  EXPECT_EQ(today.twin_ambiguous, 0);
  EXPECT_TRUE(std::isfinite(today.x));
  // Today's bytes need no upgrade.
  EXPECT_FALSE(upgradeEvent(e));
  // Installed, every reader upgrades as it reads and counts it.
  installLogUpgrades();
  bus::LogReader log(config::projectRoot() + "/tests/data/recordings/main_428ac34/robot1.lcm");
  robot_state_t m;
  int read = 0;
  while (log.next(bus::channels::kRobotState, m))
    ++read;
  EXPECT_EQ(read, 201);
  EXPECT_EQ(log.upgradedByKind().at("robot_state_t v1"), 201);
  EXPECT_EQ(log.upgradedByKind().at("team_state_t v1"), 40);
  bus::setLogUpgrade({});
}

TEST(Upgrade, ThreeWheelOdometryBecomesTodaysWithItsWheelCount) {
  // The recording of main at 9085e4b holds ODOMETRY with three ticks and no wheel_count.
  bus::LogReader raw(config::projectRoot() + "/tests/data/recordings/main_9085e4b/robot1.lcm");
  bus::LogEvent e;
  int found = 0;
  while (raw.nextEvent(e)) {
    if (e.channel != bus::channels::kOdometry.name) continue;
    fieldline_legacy::odometry_v1_t old{};
    ASSERT_EQ(old.decode(e.data.data(), 0, static_cast<int>(e.data.size())),
              static_cast<int>(e.data.size()));
    const auto applied = upgradeEvent(e);
    ASSERT_TRUE(applied);
    EXPECT_EQ(*applied, "odometry_t v1");
    odometry_t today{};
    ASSERT_EQ(today.decode(e.data.data(), 0, static_cast<int>(e.data.size())),
              static_cast<int>(e.data.size()));
    EXPECT_EQ(today.wheel_count, 3);
    ASSERT_EQ(today.ticks.size(), 3u);
    for (int i = 0; i < 3; ++i) {
      EXPECT_EQ(today.ticks[static_cast<std::size_t>(i)], old.ticks[i]);
      EXPECT_EQ(today.wheel_current[static_cast<std::size_t>(i)], old.wheel_current[i]);
    }
    EXPECT_EQ(today.header.utime, old.header.utime);
    EXPECT_EQ(today.dx, old.dx);
    EXPECT_EQ(today.status, old.status);
    EXPECT_EQ(today.gyro_dphi, old.gyro_dphi);
    EXPECT_FALSE(bus::validate(today)) << *bus::validate(today);
    if (++found == 20) break;
  }
  EXPECT_EQ(found, 20);
}

}  // namespace bus_recording_test
}  // namespace fieldline::recording
