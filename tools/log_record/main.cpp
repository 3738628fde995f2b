// fieldline-log-record: records fieldline channels of one bus into an LCM log through
// bus::LogWriter (the format lcm-logger writes), optionally skipping the first events and
// stopping after a number of them, so small test fixtures come out the same size every time.
// Only valid messages are written: each is checked as a node would check it.
#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "common/bus/checked_decode.hpp"
#include "common/bus/cli.hpp"
#include "common/bus/log_file.hpp"
#include "common/bus/node.hpp"
#include "common/cli/cli.hpp"

using namespace fieldline;

namespace {

struct Options {
  std::vector<std::string> channels;
  std::string output;
  std::int64_t skip = 0;
  std::int64_t count = 0;
  double timeout_s = 30.0;

  void addTo(cli::App& app) {
    app.add_option("--channel", channels, "Channel to record (repeatable; default: all)")
        ->check(cli::IsMember(
            std::vector<std::string>(bus::kAllChannelNames.begin(), bus::kAllChannelNames.end())));
    app.add_option("--output,-o", output, "Log file to write (overwritten)")->required();
    app.add_option("--skip", skip, "Valid messages to let pass before recording")
        ->check(cli::Range(std::int64_t{0}, std::int64_t{1} << 40));
    app.add_option("--count", count, "Stop after this many recorded messages (0: until stopped)")
        ->check(cli::Range(std::int64_t{0}, std::int64_t{1} << 40));
    app.add_option("--timeout", timeout_s, "Give up after this many seconds")
        ->check(cli::Range(0.1, 86400.0))
        ->capture_default_str();
  }
};

// Records until stopped, --count messages were written or --timeout passed; the exit code.
int record(const Options& options, const bus::CommonOptions& common) {
  SystemClock clock;
  bus::Node node({.process = "log_record",
                  .robot_id = common.robot,
                  .url = common.bus_url,
                  .status_period_us = 0},
                 clock);
  bus::LogWriter writer(options.output);
  const std::vector<std::string>& channels = options.channels;
  const std::int64_t count = options.count;
  std::int64_t seen = 0;
  std::int64_t rejected = 0;
  node.subscribeAllRaw([&](const std::string& channel, const void* data, int size) {
    if (!channels.empty() && std::find(channels.begin(), channels.end(), channel) == channels.end())
      return;
    if (count > 0 && writer.eventsWritten() >= count) return;
    if (auto rejection = bus::checkEncoded(channel, data, size, clock.now(),
                                           node.options().future_tolerance_us)) {
      ++rejected;
      std::fprintf(stderr, "log_record: %s: %s (%s)\n", channel.c_str(), rejection->text.c_str(),
                   rejection->kind.c_str());
      return;
    }
    if (seen++ < options.skip) return;
    try {
      writer.write(channel, clock.now(), data, size);
    } catch (const bus::LogError& e) {
      node.reportError("log_write", e.what());
      node.requestStop();
    }
  });
  bus::installStopSignals();
  const Utime deadline = clock.now() + static_cast<Utime>(options.timeout_s * 1e6);
  while (!node.stopRequested() && clock.now() < deadline &&
         (count == 0 || writer.eventsWritten() < count)) {
    node.spinOnce(50);
  }
  writer.flush();
  fmt::print("{}: {} messages recorded, {} rejected\n", options.output, writer.eventsWritten(),
             rejected);
  if (count > 0 && writer.eventsWritten() < count) {
    fmt::print(stderr, "log_record: only {} of {} messages within {} s\n", writer.eventsWritten(),
               count, options.timeout_s);
    return 1;
  }
  return node.status().errorCount("log_write") > 0 ? 1 : 0;
}

}  // namespace

int main(int argc, char** argv) {
  cli::App app{
      "Records fieldline channels of a robot's bus (or the simulator's) into an LCM log, checking "
      "every message as a node would. Example: fieldline-log-record --robot 1 --channel "
      "CAMERA_IMAGE --skip 60 --count 15 --output camera.lcmlog"};
  bus::CommonOptions common;
  common.addTo(app);
  Options options;
  options.addTo(app);
  try {
    app.parse(argc, argv);
  } catch (const cli::ParseError& e) {
    // --help is a ParseError too (exit code 0); every real one is a bad argument: 2.
    return app.exit(e) == 0 ? 0 : 2;
  }
  common.resolve("log_record");
  return bus::runMain("log_record", [&] { return record(options, common); });
}
