// fieldline-record: records a robot's bus (on the robot: `--robot N`) or the whole simulated team
// (`--team`: the simulator's bus and every robot's) into a recording directory that describes
// itself: every file starts with a RECORDING_INFO holding the robot's clock model, the settings
// of its processes (the launch file), the field and the software version (docs/replay.md).
//
//   fieldline-record --robot 3 -o rec/                  # rec/robot3.lcm
//   fieldline-record --team -o rec/ --images 10         # rec/sim.lcm, rec/robot1.lcm, ...
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "common/bus/cli.hpp"
#include "common/bus/node.hpp"
#include "common/bus/robot_clock.hpp"
#include "common/bus/urls.hpp"
#include "common/cli/cli.hpp"
#include "common/config/config.hpp"
#include "tools/launch/robot_clocks.hpp"
#include "tools/recording/bus_recording.hpp"
#include "tools/recording/recording_info.hpp"

using namespace fieldline;

namespace {

struct Options {
  bool team = false;
  std::vector<int> robots{1, 2, 3, 4, 5, 6};
  bool no_sim = false;
  std::string out_dir;
  std::string launch;
  std::string field = "msl";
  double duration_s = 0.0;
  double max_mb = 0.0;
  double status_period_s = 1.0;
  bus::BusAddress address;
  recording::BusRecordingOptions recording;

  void addTo(cli::App& app) {
    app.add_flag("--team", team,
                 "Record the simulator's bus and every robot's (--robots) into one directory, "
                 "each robot with its clock from the launch file");
    app.add_option("--robots", robots, "--team: the robots whose buses to record")
        ->delimiter(',')
        ->check(cli::Range(1, 6))
        ->capture_default_str();
    app.add_flag("--no-sim", no_sim, "--team: leave out the simulator's bus (a real team)");
    app.add_option("--output,-o", out_dir, "Recording directory (created)")->required();
    app.add_option("--launch", launch,
                   "The launch file the robots run (its processes' settings and, with --team, "
                   "the robots' clocks go into the recording); --team's default: sim_team");
    app.add_option("--field", field,
                   "Field preset (without --launch; with it, fusion's --field there)")
        ->capture_default_str();
    app.add_option("--channel", recording.channels,
                   "Channel to record (repeatable; default: every channel)")
        ->check(cli::IsMember(
            std::vector<std::string>(bus::kAllChannelNames.begin(), bus::kAllChannelNames.end())));
    app.add_option("--images", recording.image_every,
                   "CAMERA_IMAGE: record every Nth frame of each camera (1: all; 0: none, about "
                   "4 MB/s per robot less)")
        ->check(cli::Range(0, 1000))
        ->capture_default_str();
    app.add_option("--max-mb", max_mb,
                   "Start a new file (NAME_part002.lcm, ...) when one reaches this many MB "
                   "(0: no limit)")
        ->check(cli::Range(0.0, 1e6))
        ->capture_default_str();
    app.add_option("--max-files", recording.max_files,
                   "With --max-mb: keep at most this many files per bus, deleting the oldest "
                   "(0: keep all)")
        ->check(cli::Range(0, 100000))
        ->capture_default_str();
    app.add_option("--duration", duration_s, "Stop after this many seconds (0: until Ctrl-C)")
        ->check(cli::Range(0.0, 1e7))
        ->capture_default_str();
    app.add_option("--base-port", address.base_port,
                   "Port of the simulator's bus; robot N's is this + N")
        ->check(cli::Range(1, 65535 - 6))
        ->capture_default_str();
  }
};

std::string hostName() {
  char name[256] = {};
  return ::gethostname(name, sizeof name - 1) == 0 ? std::string(name) : std::string("unknown");
}

// What every file of bus `robot` says about itself.
recording_info_t baseInfo(int robot, const ClockError& clock, bool configured,
                          const recording::LaunchSettings& settings) {
  recording_info_t info{};
  info.bus_robot_id = static_cast<std::int8_t>(robot);
  info.clock_model = configured ? recording_info_t::CLOCK_CONFIGURED : recording_info_t::CLOCK_NONE;
  info.clock_offset_us = clock.offset_us;
  info.clock_drift_ppm = clock.drift_ppm;
  info.clock_reference_us = clock.reference_us;
  info.host = hostName();
  info.version = recording::buildVersion();
  info.field_name = settings.field_name;
  info.field_yaml = settings.field_yaml;
  info.settings_yaml = settings.settings_yaml;
  return info;
}

struct Recorded {
  int robot = 0;
  bus::BusId bus = bus::kPrimaryBus;
  std::unique_ptr<recording::BusRecording> file;
  ClockError clock;
  bool warned_clock = false;
};

// Which buses, each robot with its clock: the launch file's (the simulated team, the same
// reference time as the launcher when FIELDLINE_CLOCK_REFERENCE_US is set, as scripts/demo and
// fieldline-eval set it), or on a robot the one its processes get from the environment (none on
// a real robot).
std::vector<Recorded> busesToRecord(const Options& o, const bus::CommonOptions& common) {
  std::vector<Recorded> buses;
  if (o.team) {
    const launch::RobotClocks clocks =
        launch::parseRobotClocks(config::Node::loadFile(config::resolvePreset("launch", o.launch)),
                                 launch::clockReferenceNow());
    if (!o.no_sim) buses.push_back({.robot = 0});
    for (int r : o.robots)
      buses.push_back({.robot = r, .clock = clocks.of(r)});
  } else {
    buses.push_back({.robot = common.robot, .clock = bus::robotClockErrorFromEnvironment()});
  }
  return buses;
}

// Once a second: the status metrics, and the clock check (the model against the traffic).
void reportProgress(bus::Node& node, std::vector<Recorded>& buses) {
  std::int64_t bytes = 0, events = 0, skipped = 0;
  for (Recorded& b : buses) {
    bytes += b.file->bytesWritten();
    events += b.file->eventsWritten();
    skipped += b.file->imagesSkipped();
    for (const auto& [kind, n] : b.file->refused())
      node.setMetric(fmt::format("refused_{}_robot{}", kind, b.robot), static_cast<double>(n));
    const auto& observed = b.file->observedClock();
    if (b.robot == 0 || !observed) continue;
    // Compared where the traffic was, not extrapolated to now.
    const Utime at = b.file->observedAt();
    const double disagreement_ms =
        static_cast<double>(observed->ownAt(at) - truthToOwn(b.clock, at)) * 1e-3;
    node.setMetric(fmt::format("clock_check_ms_robot{}", b.robot), disagreement_ms);
    // More than the delivery delay: the clock model written into the recording is wrong.
    if (std::abs(disagreement_ms) > 20.0) {
      node.status().setWarning(fmt::format("clock{}", b.robot),
                               fmt::format("robot {}'s traffic is {:.1f} ms off its recorded clock",
                                           b.robot, disagreement_ms));
      if (!b.warned_clock) {
        spdlog::warn(
            "robot {}'s stamps are {:.1f} ms off the clock model in the recording "
            "(offset {:.3f} s): the launch file's clocks are not the running team's?",
            b.robot, disagreement_ms, b.clock.offset_us * 1e-6);
        b.warned_clock = true;
      }
    } else {
      node.status().setWarning(fmt::format("clock{}", b.robot), "");
    }
  }
  node.setMetric("mb_written", static_cast<double>(bytes) / (1024.0 * 1024.0));
  node.setMetric("events_written", static_cast<double>(events));
  node.setMetric("images_skipped", static_cast<double>(skipped));
  for (Recorded& b : buses)
    b.file->flush();
}

// Every file's last RECORDING_INFO and its summary; 1 when a write failed or a bus was silent.
int finishRecording(bus::Node& node, std::vector<Recorded>& buses, SystemClock& clock) {
  int rc = node.status().errorCount("log_write") > 0 ? 1 : 0;
  for (Recorded& b : buses) {
    b.file->writeInfo(clock.now());
    b.file->flush();
    std::string refused;
    for (const auto& [kind, n] : b.file->refused())
      refused += fmt::format(" {} {}", kind, n);
    fmt::print("{}: {} messages in {} file(s), {:.1f} MB, refused:{}{}\n", b.file->currentPath(),
               b.file->eventsWritten(), b.file->filesStarted(),
               static_cast<double>(b.file->bytesWritten()) / (1024.0 * 1024.0),
               refused.empty() ? " none" : refused,
               b.file->lastRefusal().empty() ? "" : " (last: " + b.file->lastRefusal() + ")");
    if (b.file->eventsWritten() == 0) {
      fmt::print(stderr, "record: nothing was heard on {}'s bus\n",
                 b.robot == 0 ? std::string("the simulator") : "robot " + std::to_string(b.robot));
      rc = 1;
    }
  }
  return rc;
}

int record(Options& o, const bus::CommonOptions& common) {
  SystemClock clock;
  o.recording.max_file_bytes = static_cast<std::int64_t>(o.max_mb * 1024.0 * 1024.0);
  if (o.team && o.launch.empty()) o.launch = "sim_team";
  const recording::LaunchSettings settings =
      o.launch.empty()
          ? recording::settingsForField(o.field)
          : recording::settingsFromLaunchFile(config::resolvePreset("launch", o.launch));

  std::vector<Recorded> buses = busesToRecord(o, common);
  const std::string primary = o.team && !o.no_sim ? bus::simBusUrl(o.address)
                              : o.team            ? bus::robotBusUrl(o.robots.front(), o.address)
                                                  : common.bus_url;
  // The recorder's own SERVICE_STATUS is stamped like its bus's other processes: on a robot with
  // the robot's clock, in the team with the simulator's. Log times are the system clock's.
  const RobotClock node_clock(o.team ? ClockError{} : buses.front().clock);
  bus::Node node({.process = "recorder",
                  .robot_id = o.team ? 0 : common.robot,
                  .url = primary,
                  .status_period_us = static_cast<Utime>(o.status_period_s * 1e6)},
                 node_clock);
  for (Recorded& b : buses) {
    const std::string url = b.robot == 0 ? bus::simBusUrl(o.address)
                            : o.team     ? bus::robotBusUrl(b.robot, o.address)
                                         : common.bus_url;
    b.bus = url == primary ? bus::kPrimaryBus : node.addBus(url);
    const bool configured = b.clock.offset_us != 0 || b.clock.drift_ppm != 0.0;
    b.file = std::make_unique<recording::BusRecording>(
        o.out_dir, b.robot == 0 ? "sim" : "robot" + std::to_string(b.robot),
        baseInfo(b.robot, b.clock, configured, settings), o.recording);
    b.file->writeInfo(clock.now());
    spdlog::info("recording {} into {} (robot clock: offset {:.3f} s, drift {:.1f} ppm)", url,
                 b.file->currentPath(), b.clock.offset_us * 1e-6, b.clock.drift_ppm);
    recording::BusRecording* file = b.file.get();
    node.subscribeAllRaw(
        [&node, &clock, file](const std::string& channel, const void* data, int size) {
          try {
            file->write(channel, clock.now(), data, size);
          } catch (const bus::LogError& e) {
            node.reportError("log_write", e.what());
            node.requestStop();
          }
        },
        b.bus);
  }

  node.every(kMicrosPerSecond, [&] { reportProgress(node, buses); });

  bus::installStopSignals();
  const Utime end = o.duration_s > 0.0 ? clock.now() + static_cast<Utime>(o.duration_s * 1e6) : 0;
  while (!node.stopRequested() && !bus::stopSignalReceived() && (end == 0 || clock.now() < end))
    node.spinOnce(100);

  return finishRecording(node, buses, clock);
}

}  // namespace

int main(int argc, char** argv) {
  cli::App app{
      "Records a robot's bus (--robot N, on the robot) or the simulated team (--team: the "
      "simulator's bus and every robot's) into a recording directory (robotN.lcm, sim.lcm; "
      "lcm-logger's format) that describes itself: each file starts with a RECORDING_INFO "
      "holding the robot's clock model, its processes' settings (the launch file), the field "
      "and the version. Channels can be chosen, camera images left out or decimated, files "
      "split by size. Replay with fieldline-replay, score with fieldline-eval --log, watch with "
      "fieldline-viewer --log (docs/replay.md).\n"
      "Examples:\n"
      "  fieldline-record --robot 3 --launch real_robot -o /data/match1\n"
      "  fieldline-record --team -o rec/ --images 10 --max-mb 500"};
  bus::CommonOptions common;
  common.addTo(app);
  Options options;
  options.addTo(app);
  FIELDLINE_PARSE(app, argc, argv);
  common.resolve("record");
  if (common.check_args) return 0;
  return bus::runMain("record", [&] { return record(options, common); });
}
