// fieldline-bus-dump: prints the messages of a bus or an LCM log as JSON lines, one object per
// message with its channel, its log or receive time and every field by name, so people can
// script against the bus (Debian has no LCM Python binding). Every message is checked as a node
// would check it; bad ones are reported on stderr with the reason and counted, never printed.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "common/bus/checked_decode.hpp"
#include "common/bus/cli.hpp"
#include "common/bus/log_file.hpp"
#include "common/bus/node.hpp"
#include "common/bus/urls.hpp"
#include "common/cli/cli.hpp"
#include "tools/bus_dump/message_json.hpp"
#include "tools/json/json_text.hpp"
#include "tools/recording/upgrade.hpp"

using namespace fieldline;

namespace {

struct Settings {
  std::vector<std::string> channels;  // empty: all
  // Not empty: one CSV file per channel in this directory instead of JSON lines.
  std::string csv_dir;
  std::int64_t count = 0;  // 0: no limit
  std::optional<double> duration_s;
  bus_dump::JsonOptions json;
};

bool wanted(const Settings& settings, std::string_view channel) {
  return settings.channels.empty() || std::find(settings.channels.begin(), settings.channels.end(),
                                                channel) != settings.channels.end();
}

// Counts what was printed and what was refused, and prints the summary on stderr at the end.
class Dumper {
 public:
  explicit Dumper(const Settings& settings) : settings_(settings) {}

  // Prints one checked message; one that does not decode is counted as rejected instead.
  void print(std::string_view channel, std::string_view time_key, Utime time,
             std::optional<std::int64_t> event_number, const void* data, int size) {
    if (!settings_.csv_dir.empty()) {
      printCsv(channel, time, data, size);
      return;
    }
    line_.clear();
    line_ += "{\"channel\":";
    json::appendString(line_, channel);
    if (event_number) line_ += fmt::format(",\"event\":{}", *event_number);
    line_ += fmt::format(",\"{}\":{},\"message\":", time_key, time);
    if (!bus_dump::appendMessageJson(line_, channel, data, size, settings_.json)) {
      reject(channel, "decode", "does not decode after passing the checks");
      return;
    }
    line_ += "}\n";
    std::fwrite(line_.data(), 1, line_.size(), stdout);
    std::fflush(stdout);  // lines go to pipes and scripts as they come
    ++printed_;
  }

  // One row in the channel's CSV file (DIR/CHANNEL.csv, its header line written first).
  void printCsv(std::string_view channel, Utime time, const void* data, int size) {
    auto it = csv_.find(std::string(channel));
    if (it == csv_.end()) {
      const std::string path = settings_.csv_dir + "/" + std::string(channel) + ".csv";
      it = csv_.emplace(std::string(channel), std::ofstream(path)).first;
      line_.clear();
      if (!it->second || !bus_dump::appendCsvHeader(line_, channel)) {
        reject(channel, "csv", "cannot write " + path);
        csv_.erase(it);
        return;
      }
      it->second << line_ << '\n';
    }
    line_.clear();
    if (!bus_dump::appendCsvRow(line_, channel, time, data, size, settings_.json)) {
      reject(channel, "decode", "does not decode after passing the checks");
      return;
    }
    it->second << line_ << '\n';
    ++printed_;
  }

  void reject(std::string_view channel, const std::string& kind, const std::string& text) {
    ++rejected_[kind];
    std::fprintf(stderr, "bus_dump: rejected %s: %s (%s)\n",
                 channel.empty() ? "-" : std::string(channel).c_str(), text.c_str(), kind.c_str());
  }

  bool done() const { return settings_.count > 0 && printed_ >= settings_.count; }

  void summary() const {
    std::int64_t total = 0;
    std::string kinds;
    for (const auto& [kind, n] : rejected_) {
      total += n;
      kinds += fmt::format("{}{}: {}", kinds.empty() ? "" : ", ", kind, n);
    }
    std::fprintf(stderr, "bus_dump: %lld messages printed, %lld rejected%s\n",
                 static_cast<long long>(printed_), static_cast<long long>(total),
                 kinds.empty() ? "" : (" (" + kinds + ")").c_str());
  }

 private:
  const Settings& settings_;
  std::string line_;
  std::map<std::string, std::ofstream> csv_;
  std::int64_t printed_ = 0;
  std::map<std::string, std::int64_t> rejected_;
};

int dumpLog(const std::string& path, const Settings& settings) {
  bus::LogReader log(path);
  Dumper dumper(settings);
  std::int64_t reported = 0;  // rejections of the reader already reported
  // The reader counts damage and rejections itself; report each new one once.
  const auto reportNew = [&] {
    const std::int64_t total = log.rejectedTotal();
    const auto& recent = log.recentRejections();
    const auto fresh = static_cast<std::size_t>(
        std::min<std::int64_t>(total - reported, static_cast<std::int64_t>(recent.size())));
    for (std::size_t i = recent.size() - fresh; i < recent.size(); ++i) {
      const bus::LogRejection& r = recent[i];
      dumper.reject(
          r.channel, r.reason.kind,
          fmt::format("event {} at offset {}: {}", r.event_number, r.offset, r.reason.text));
    }
    reported = total;
  };
  std::optional<Utime> first_time;
  bus::LogEvent event;
  while (!dumper.done() && log.nextEvent(event)) {
    reportNew();  // damage skipped on the way to this event
    if (!wanted(settings, event.channel)) continue;
    if (!first_time) first_time = event.timestamp;
    if (settings.duration_s &&
        static_cast<double>(event.timestamp - *first_time) > *settings.duration_s * 1e6)
      break;
    if (!log.accept(event)) {
      reportNew();
      continue;
    }
    dumper.print(event.channel, "log_utime", event.timestamp, event.number, event.data.data(),
                 static_cast<int>(event.data.size()));
  }
  reportNew();  // damage at the end of the file
  dumper.summary();
  for (const auto& [name, n] : log.upgradedByKind()) {
    std::fprintf(stderr, "bus_dump: %lld events of %s upgraded to today's type\n",
                 static_cast<long long>(n), name.c_str());
  }
  return 0;
}

int dumpBus(const std::string& url, const Settings& settings) {
  SystemClock clock;
  bus::Node node({.process = "bus_dump", .robot_id = 0, .url = url, .status_period_us = 0}, clock);
  Dumper dumper(settings);
  node.subscribeAllRaw([&](const std::string& channel, const void* data, int size) {
    if (dumper.done() || !wanted(settings, channel)) return;
    const Utime now = clock.now();
    if (auto rejection =
            bus::checkEncoded(channel, data, size, now, node.options().future_tolerance_us)) {
      dumper.reject(channel, rejection->kind, rejection->text);
      return;
    }
    dumper.print(channel, "receive_utime", now, std::nullopt, data, size);
  });
  bus::installStopSignals();
  // A plain bound and a flag, not an optional: g++ 12 at -O1 reports a false
  // -Wmaybe-uninitialized on an optional compared in the loop.
  const bool bounded = settings.duration_s.has_value();
  const Utime end =
      bounded ? clock.now() + static_cast<Utime>(*settings.duration_s * 1e6) : Utime{0};
  while (!dumper.done() && !bus::stopSignalReceived() && (!bounded || clock.now() < end))
    node.spinOnce(50);
  dumper.summary();
  return 0;
}

// Where to read (exactly one of robot, sim, url, log) and what to print.
struct Options {
  std::optional<int> robot;
  bool sim = false;
  std::string url;
  std::string log_path;
  Settings settings;
  bool follow = false;
  double duration_s = 0.0;
  bus::BusAddress address;
  cli::Option* duration = nullptr;

  void addTo(cli::App& app) {
    app.add_option("--robot", robot, "Dump robot N's bus")->check(cli::Range(1, 6));
    app.add_flag("--sim", sim, "Dump the simulator's bus");
    app.add_option("--url", url, "Dump the bus at this LCM URL");
    app.add_option("--log", log_path, "Dump an LCM log file instead of a bus")
        ->check(cli::ExistingFile);
    app.add_option("--base-port", address.base_port,
                   "Port of the simulator's bus; robot N is base+N (with --robot/--sim)")
        ->capture_default_str();
    app.add_option("--channel", settings.channels, "Channel to dump (repeatable; default: all)")
        ->check(cli::IsMember(
            std::vector<std::string>(bus::kAllChannelNames.begin(), bus::kAllChannelNames.end())));
    app.add_option("--count", settings.count, "Stop after this many printed messages")
        ->check(cli::Range(std::int64_t{1}, std::int64_t{1} << 40));
    duration = app.add_option("--duration", duration_s,
                              "Stop after this many seconds (bus: wall time; log: log time "
                              "from the first event of the chosen channels)")
                   ->check(cli::Range(1e-6, 1e7));
    app.add_flag("--follow", follow,
                 "Bus only: dump until interrupted (a bus dump needs --count, --duration or this)");
    app.add_flag("--image-data", settings.json.image_data,
                 "Print image_t pixel bytes as a JSON array instead of size and hash");
    app.add_option("--csv", settings.csv_dir,
                   "Write one CSV file per channel into this directory (created) instead of JSON "
                   "lines: DIR/ROBOT_STATE.csv, ... with log_utime (or the receive time) and one "
                   "column per field");
  }

  // Throws cli::ValidationError when the combination is not allowed.
  void check() const {
    const int sources =
        (robot ? 1 : 0) + (sim ? 1 : 0) + (url.empty() ? 0 : 1) + (log_path.empty() ? 0 : 1);
    if (sources != 1)
      throw cli::ValidationError("source", "give exactly one of --robot, --sim, --url, --log");
    if (!log_path.empty() && follow)
      throw cli::ValidationError("--follow", "--follow is for buses; a log is read to its end");
    if (log_path.empty() && settings.count == 0 && duration->count() == 0 && !follow)
      throw cli::ValidationError("bounds",
                                 "a bus dump needs --count, --duration or --follow (until Ctrl-C)");
  }
};

}  // namespace

int main(int argc, char** argv) {
  cli::App app{
      "Prints the messages of a fieldline bus or an LCM log as JSON lines: one object per "
      "message with \"channel\", \"log_utime\" and \"event\" (log) or \"receive_utime\" (bus), "
      "and \"message\" holding every field by name (arrays as JSON arrays; image pixels as size "
      "and FNV-1a hash unless --image-data). Messages are checked as a node checks them; bad "
      "ones are reported on stderr and counted, never printed. The writers are generated from "
      "lcmtypes/ at build time: every field of every type. --csv DIR writes a CSV file per "
      "channel instead. Examples:\n"
      "  fieldline-bus-dump --log run.lcmlog --channel ROBOT_STATE | jq .message.x\n"
      "  fieldline-bus-dump --robot 2 --channel ODOMETRY --count 10\n"
      "  fieldline-bus-dump --log rec/robot2.lcm --csv rec/robot2_csv"};
  Options o;
  o.addTo(app);
  try {
    app.parse(argc, argv);
    o.check();
  } catch (const cli::ParseError& e) {
    // --help is a ParseError too (exit code 0); every real one is a bad argument: 2.
    return app.exit(e) == 0 ? 0 : 2;
  }
  if (o.duration->count() > 0) o.settings.duration_s = o.duration_s;
  if (!o.settings.csv_dir.empty()) std::filesystem::create_directories(o.settings.csv_dir);

  recording::installLogUpgrades();
  return bus::runMain("bus_dump", [&]() -> int {
    if (!o.log_path.empty()) return dumpLog(o.log_path, o.settings);
    const std::string bus_url = !o.url.empty() ? o.url
                                : o.sim        ? bus::simBusUrl(o.address)
                                               : bus::robotBusUrl(*o.robot, o.address);
    return dumpBus(bus_url, o.settings);
  });
}
