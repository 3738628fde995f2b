// LCM logs: the reader delivers what the writer wrote, skips damaged stretches up to the next
// intact event, and puts every event through the checks live traffic gets (decode into the
// channel's type, validate, no utime from the future), counting what it rejects with the event
// number; the replay driver feeds a log through nodes on memq:// in log-time order.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <unistd.h>

#include "common/bus/log_file.hpp"
#include "common/bus/node.hpp"
#include "common/bus/replay.hpp"

namespace fieldline::bus {
namespace log_test {

constexpr Utime kStart = 1'800'000'000'000'000;

odometry_t odometry(Utime utime, double dx) {
  odometry_t m{};
  m.header.utime = utime;
  m.header.utime_published = utime + 1000;
  m.header.robot_id = 2;
  m.controller_utime = utime;
  m.dx = dx;
  return m;
}

motion_command_t command(Utime utime, double vx) {
  motion_command_t m{};
  m.header.utime = utime;
  m.header.utime_published = utime;
  m.vx = vx;
  m.deadline_utime = utime + 100'000;
  m.source = motion_command_t::SOURCE_PILOT;
  return m;
}

template <typename Msg>
std::vector<std::uint8_t> encoded(const Msg& m) {
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

// One event in LCM's framing, built by hand so tests can damage it.
std::string eventBytes(std::int64_t number, Utime timestamp, const std::string& channel,
                       const std::vector<std::uint8_t>& data) {
  std::string out;
  auto put = [&](std::uint64_t v, int bytes) {
    for (int i = bytes - 1; i >= 0; --i)
      out.push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
  };
  put(0xEDA1DA01u, 4);
  put(static_cast<std::uint64_t>(number), 8);
  put(static_cast<std::uint64_t>(timestamp), 8);
  put(channel.size(), 4);
  put(data.size(), 4);
  out += channel;
  out.append(data.begin(), data.end());
  return out;
}

class LogTest : public ::testing::Test {
 protected:
  std::string path = (std::filesystem::temp_directory_path() /
                      ("fieldline_log_test_" + std::to_string(::getpid()) + ".lcmlog"))
                         .string();
  void TearDown() override { std::filesystem::remove(path); }
  void writeFile(const std::string& bytes) {
    std::ofstream out(path, std::ios::binary);
    out << bytes;
  }
  std::string readFile() const {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  }
};

TEST_F(LogTest, ReadsBackWhatTheWriterWroteTypedAndInOrder) {
  {
    LogWriter writer(path);
    for (int k = 0; k < 3; ++k) {
      writer.write(channels::kOdometry, kStart + k * 20'000, odometry(kStart + k * 20'000, k));
      writer.write(channels::kMotionCommand, kStart + k * 20'000 + 5,
                   command(kStart + k * 20'000, 0.1 * k));
    }
    EXPECT_EQ(writer.eventsWritten(), 6);
  }
  LogReader reader(path);
  odometry_t m;
  LogEvent event;
  for (int k = 0; k < 3; ++k) {
    ASSERT_TRUE(reader.next(channels::kOdometry, m, &event)) << k;
    EXPECT_EQ(event.number, 2 * k);
    EXPECT_EQ(event.timestamp, kStart + k * 20'000);
    EXPECT_EQ(event.channel, "ODOMETRY");
    EXPECT_EQ(m.header.utime, kStart + k * 20'000);
    EXPECT_EQ(m.dx, k);
  }
  EXPECT_FALSE(reader.next(channels::kOdometry, m));
  EXPECT_EQ(reader.rejectedTotal(), 0);
  EXPECT_EQ(reader.eventsRead(), 6);

  // Every channel, checked: all six, in file order.
  reader.rewind();
  std::vector<std::string> channel_order;
  while (reader.nextChecked(event))
    channel_order.push_back(event.channel);
  EXPECT_EQ(channel_order,
            (std::vector<std::string>{"ODOMETRY", "MOTION_COMMAND", "ODOMETRY", "MOTION_COMMAND",
                                      "ODOMETRY", "MOTION_COMMAND"}));
  EXPECT_EQ(reader.rejectedTotal(), 0);
}

TEST_F(LogTest, DamagedStretchesAreSkippedUpToTheNextIntactEvent) {
  const std::string ch(channels::kOdometry.name);
  std::string bytes = eventBytes(0, kStart, ch, encoded(odometry(kStart, 0)));
  bytes += "garbage between events";
  // An event header claiming 2 GB of data: taken as damage, not allocated.
  std::string huge = eventBytes(1, kStart + 1, ch, encoded(odometry(kStart + 1, 1)));
  huge[24] = '\x7f';
  bytes += huge;
  bytes += eventBytes(2, kStart + 2, ch, encoded(odometry(kStart + 2, 2)));
  // The last event is cut off: the log was still being written.
  const std::string last = eventBytes(3, kStart + 3, ch, encoded(odometry(kStart + 3, 3)));
  bytes += last.substr(0, last.size() - 10);
  writeFile(bytes);

  LogReader reader(path);
  odometry_t m;
  std::vector<double> got;
  while (reader.next(channels::kOdometry, m))
    got.push_back(m.dx);
  // Event 0 is followed by garbage instead of the next sync word, so its length is not trusted
  // (LCM's rule); event 1's payload without a sane header is not an event; event 2 is intact.
  EXPECT_EQ(got, (std::vector<double>{2}));
  EXPECT_GE(reader.rejectedByKind().at("damaged"), 3);
  EXPECT_EQ(reader.rejectedByKind().at("truncated"), 1);
  EXPECT_EQ(reader.eventsRead(), 1);
  // Nothing of the damaged file survives as a wrong message: the next read still ends cleanly.
  EXPECT_FALSE(reader.next(channels::kOdometry, m));
}

TEST_F(LogTest, InvalidMessagesAreCountedWithTheirEventNumberAndSkipped) {
  {
    LogWriter writer(path);
    writer.write(channels::kOdometry, kStart, odometry(kStart, 1));
    writer.write(channels::kOdometry, kStart + 10,
                 odometry(kStart + 10, std::numeric_limits<double>::quiet_NaN()));
    writer.write(channels::kOdometry, kStart + 20, odometry(kStart + 20, 3));
    // Stamped 2 s after the moment it was logged: from the future.
    writer.write(channels::kOdometry, kStart + 30, odometry(kStart + 2'000'030, 4));
  }
  LogReader reader(path);
  odometry_t m;
  std::vector<double> got;
  while (reader.next(channels::kOdometry, m))
    got.push_back(m.dx);
  EXPECT_EQ(got, (std::vector<double>{1, 3}));
  EXPECT_EQ(reader.rejectedByKind().at("invalid"), 1);
  EXPECT_EQ(reader.rejectedByKind().at("future_utime"), 1);
  ASSERT_EQ(reader.recentRejections().size(), 2u);
  const LogRejection& nan = reader.recentRejections()[0];
  EXPECT_EQ(nan.event_number, 1);
  EXPECT_EQ(nan.channel, "ODOMETRY");
  EXPECT_NE(nan.reason.text.find("dx is not finite"), std::string::npos) << nan.reason.text;
  EXPECT_EQ(reader.recentRejections()[1].event_number, 3);
}

TEST_F(LogTest, AnotherTypeOnAChannelIsRejectedAsWrongType) {
  {
    LogWriter writer(path);
    // An odometry message on MOTION_COMMAND (a misconfigured publisher, a renamed channel).
    writer.write(channels::kMotionCommand.name, kStart, encoded(odometry(kStart, 1)).data(),
                 static_cast<int>(encoded(odometry(kStart, 1)).size()));
    const std::vector<std::uint8_t> garbage{1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12};
    writer.write(channels::kMotionCommand.name, kStart + 1, garbage.data(),
                 static_cast<int>(garbage.size()));
    writer.write(channels::kMotionCommand, kStart + 2, command(kStart + 2, 0.5));
    // A channel fieldline does not know.
    writer.write("SOMEONE_ELSES", kStart + 3, garbage.data(), static_cast<int>(garbage.size()));
  }
  LogReader reader(path);
  LogEvent event;
  std::vector<std::int64_t> accepted;
  while (reader.nextChecked(event))
    accepted.push_back(event.number);
  EXPECT_EQ(accepted, std::vector<std::int64_t>{2});
  EXPECT_EQ(reader.rejectedByKind().at("wrong_type"), 1);
  EXPECT_EQ(reader.rejectedByKind().at("decode"), 1);
  EXPECT_EQ(reader.rejectedByKind().at("unknown_channel"), 1);
  EXPECT_NE(reader.recentRejections()[0].reason.text.find("odometry_t"), std::string::npos)
      << reader.recentRejections()[0].reason.text;

  // The same through a live node: the same kinds.
  SimulatedClock clock{kStart + 10};
  auto memq = Connection::open("memq://");
  Node sender{{.process = "sender", .status_period_us = 0}, clock, memq};
  Node receiver{{.process = "receiver", .status_period_us = 0}, clock, memq};
  int handled = 0;
  receiver.subscribe(channels::kMotionCommand, [&](const motion_command_t&) { ++handled; });
  const auto bytes = encoded(odometry(kStart, 1));
  sender.publishEncoded(channels::kMotionCommand.name, bytes.data(),
                        static_cast<int>(bytes.size()));
  receiver.spinOnce(0);
  EXPECT_EQ(handled, 0);
  EXPECT_EQ(receiver.status().errorCount("wrong_type"), 1);
}

TEST_F(LogTest, MissingFilesAndUnwritablePathsThrowLogError) {
  EXPECT_THROW(LogReader("/nonexistent/dir/x.lcmlog"), LogError);
  EXPECT_THROW(LogWriter("/nonexistent/dir/x.lcmlog"), LogError);
}

TEST_F(LogTest, ReplayDeliversInLogTimeOrderUnderTheSimulatedClockAndRecordsOutputs) {
  {
    LogWriter writer(path);
    for (int k = 0; k < 5; ++k) {
      writer.write(channels::kOdometry, kStart + k * 20'000,
                   odometry(kStart + k * 20'000 - 8'000, k));
    }
    writer.write(channels::kMotionCommand, kStart + 90'000, command(kStart + 90'000, 0.2));
    // Stamped before its predecessor: delivered, but the clock does not go back.
    writer.write(channels::kOdometry, kStart + 50'000, odometry(kStart + 42'000, 9));
    // Invalid: rejected by the reader, never reaches a node.
    writer.write(channels::kOdometry, kStart + 100'000,
                 odometry(kStart + 100'000, std::numeric_limits<double>::infinity()));
  }
  const std::string out_path = path + ".out";
  SimulatedClock clock{kStart - kMicrosPerSecond};
  auto memq = Connection::open("memq://");
  Node consumer{{.process = "consumer", .robot_id = 2, .status_period_us = 0}, clock, memq};
  std::vector<std::pair<double, Utime>> seen;  // (dx, clock time at delivery)
  std::vector<Utime> ticks;
  consumer.every(30'000, [&] { ticks.push_back(clock.now()); });
  // The consumer answers each odometry message with a command: the replay records it.
  consumer.subscribe(channels::kOdometry, [&](const odometry_t& m) {
    seen.emplace_back(m.dx, clock.now());
    auto answer = command(m.header.utime, m.dx / 10);
    consumer.publish(channels::kMotionCommand, answer);
  });
  Node recorder_node{{.process = "recorder", .robot_id = 2, .status_period_us = 0}, clock, memq};
  std::int64_t recorded = 0;
  {
    LogWriter out(out_path);
    LogRecorder recorder(recorder_node, out, {channels::kMotionCommand.name});
    Replay replay(clock, memq, {.channels = {std::string(channels::kOdometry.name)}});
    replay.add(consumer);
    replay.add(recorder_node);
    LogReader log(path);
    const ReplayStats& stats = replay.run(log);
    EXPECT_EQ(stats.delivered, 6);
    EXPECT_EQ(stats.skipped, 1);  // the log's own MOTION_COMMAND is not fed back
    EXPECT_EQ(stats.out_of_order, 1);
    EXPECT_EQ(log.rejectedByKind().at("invalid"), 1);
    EXPECT_EQ(consumer.status().errorCount("invalid"), 0);
    recorded = recorder.recorded();
  }
  ASSERT_EQ(seen.size(), 6u);
  for (int k = 0; k < 5; ++k) {
    EXPECT_EQ(seen[k].first, k);
    EXPECT_EQ(seen[k].second, kStart + k * 20'000);
  }
  EXPECT_EQ(seen[5].first, 9);
  EXPECT_EQ(seen[5].second, kStart + 80'000);
  // The 30 ms timer started a second before the log: it fires when the clock jumps to the first
  // event, then at most once per event as the clock passes its due times.
  EXPECT_FALSE(ticks.empty());
  EXPECT_EQ(recorded, 6);

  LogReader answers(out_path);
  motion_command_t m;
  LogEvent event;
  std::vector<Utime> answer_times;
  while (answers.next(channels::kMotionCommand, m, &event)) {
    answer_times.push_back(event.timestamp);
    EXPECT_EQ(m.header.utime_published, event.timestamp);
  }
  EXPECT_EQ(answer_times.size(), 6u);
  EXPECT_EQ(answers.rejectedTotal(), 0);
  std::filesystem::remove(out_path);
}

}  // namespace log_test
}  // namespace fieldline::bus
