// fieldline-eval: how well the team localizes. Runs the simulated team for a scenario (through
// fieldline-launch, so every process and bus is the real one) or reads a recorded LCM log,
// matches every ROBOT_STATE and BALL_STATE with SIM_WORLD truth at the same utime, writes
// summary.json and PNG plots, and ends with the one-line summary.
//
// Run it in a private network namespace so nothing else hears the buses, e.g.
//   unshare -n sh -c 'ip link set lo up; ip link set lo multicast on;
//                     ip route add 224.0.0.0/4 dev lo; build/bin/fieldline-eval --scenario kidnap'
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <sstream>
#include <thread>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "common/bus/checked_decode.hpp"
#include "common/bus/cli.hpp"
#include "common/bus/log_file.hpp"
#include "common/bus/node.hpp"
#include "common/cli/cli.hpp"
#include "common/config/config.hpp"
#include "common/field/field_model.hpp"
#include "common/scenario/scenario.hpp"
#include "common/time/offset_clock.hpp"
#include "tools/eval/evaluation.hpp"
#include "tools/eval/fault_runner.hpp"
#include "tools/eval/faults.hpp"
#include "tools/eval/image_to_pose.hpp"
#include "tools/eval/sim_truth.hpp"
#include "tools/eval/team_ball.hpp"
#include "tools/launch/launch_file.hpp"
#include "tools/launch/robot_clocks.hpp"
#include "tools/recording/clock_model.hpp"
#include "tools/recording/recording_info.hpp"
#include "tools/recording/upgrade.hpp"

using namespace fieldline;

namespace {

std::string selfDirectory() {
  std::error_code ec;
  const auto p = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::string{} : p.parent_path().string();
}

// The launch file to run. Its `scenario` setting gives the scenario to the simulator and the
// pilots, its `robot_config` setting (where it has one; sim_team.yaml does) the scenario's robot
// file to every process that models the robot's body (motor bridge, fusion, pilot), so a scenario
// with a four-wheeled robot runs four wheels end to end. Both are set in this process's
// environment (FIELDLINE_SCENARIO, FIELDLINE_ROBOT_CONFIG), where the launcher and the recorder
// read them. A copy with the values in its first line goes into out_dir/launch.yaml, for the
// record.
std::string scenarioLaunchFile(const std::string& launch_name, const std::string& scenario,
                               const std::string& robot, const std::string& out_dir) {
  const std::string path = config::resolvePreset("launch", launch_name);
  const launch::LaunchFile file = launch::loadLaunchFile(path);
  if (!file.settings.contains("scenario")) {
    throw config::Error(path +
                        ": no `scenario` setting to give the simulator and the pilots the "
                        "scenario (sim_team.yaml: `settings: {scenario: default}`, used as "
                        "{scenario} in their args)");
  }
  setenv(launch::settingVariable("scenario").c_str(), scenario.c_str(), 1);
  setenv(launch::settingVariable("robot_config").c_str(), robot.c_str(), 1);
  std::ifstream in(path);
  std::ostringstream text;
  text << "# fieldline-eval ran " << path << " with scenario=" << scenario
       << (file.settings.contains("robot_config") ? " robot_config=" + robot : std::string())
       << "\n"
       << in.rdbuf();
  std::ofstream(out_dir + "/launch.yaml") << text.str();
  return path;
}

struct Collector {
  std::vector<eval::TruthSample> truth;
  std::vector<eval::StateSample> states;
  std::vector<eval::BallSample> balls;
  std::map<int, Utime> first_lines;
  std::vector<eval::TeamSample> teams;
  // Image-to-pose latency (issue 32 item 4), on the robots' own stamps; the settle time left out.
  eval::ImageToPose image_to_pose;
  // The faults fieldline-eval caused (--fault), on the true clock.
  std::vector<eval::FaultRecord> faults;
  // The robots' clocks (launch file, or a recording's clock models): their stamps are converted
  // to the true time.
  launch::RobotClocks clocks;
  // A robot's clocks after its clock steps (--fault clockstep), and the true clock a live run
  // hears the messages on (null for a log).
  std::map<int, std::vector<ClockError>> stepped_clocks;
  const Clock* live_clock = nullptr;
  // The true time of `own`, a stamp of a message that `robot` published at `published` (its own
  // clock). After a clock step the robot's messages come on its old clock (its old processes'
  // last ones) or its new one: the clock that puts `published` closest to now is theirs (the
  // steps are seconds, the bus's latency milliseconds). On a tie (a step back to an earlier
  // clock) the newest step's clock is theirs.
  Utime trueTime(int robot, Utime own, Utime published) const {
    ClockError best = clocks.of(robot);
    const auto stepped = stepped_clocks.find(robot);
    if (stepped != stepped_clocks.end() && live_clock != nullptr) {
      const Utime now = live_clock->now();
      const auto distance = [&](const ClockError& c) {
        return std::llabs(ownToTruth(c, published) - now);
      };
      Utime best_distance = distance(best);
      std::optional<std::size_t> best_step;
      for (std::size_t i = stepped->second.size(); i-- > 0;) {
        const Utime d = distance(stepped->second[i]);
        if (d < best_distance || (d == best_distance && !best_step)) {
          best = stepped->second[i];
          best_distance = d;
          best_step = i;
        }
      }
      if (best_step) first_on_new_clock[robot].try_emplace(*best_step, ownToTruth(best, published));
    }
    return ownToTruth(best, own);
  }
  // Per robot and clock step (its index in stepped_clocks): the true time of the first message
  // on the new clock, i.e. of the restarted processes.
  mutable std::map<int, std::map<std::size_t, Utime>> first_on_new_clock;
  // The teammates' TEAM_STATE for the clock steps' scores (faults.hpp); t and pose_t in s since
  // the epoch, true time.
  std::vector<eval::TeamLinkSample> team_link;
  std::size_t clock_steps_noted = 0;

  void subscribe(bus::Node& node, bus::BusId sim_bus, const std::vector<bus::BusId>& robot_buses) {
    node.subscribe(
        bus::channels::kSimWorld, [this](const world_state_t& w) { onSimWorld(w); }, sim_bus);
    for (const bus::BusId b : robot_buses) {
      node.subscribe(
          bus::channels::kRobotState, [this](const robot_state_t& m) { onRobotState(m); }, b);
      node.subscribe(
          bus::channels::kVisionLines, [this](const line_contours_t& m) { onLines(m); }, b);
      node.subscribe(
          bus::channels::kCameraImage,
          [this](const image_t& m) {
            image_to_pose.onImage(m.header.robot_id, m.header.utime, m.header.utime_published);
          },
          b);
      node.subscribe(
          bus::channels::kBallState, [this](const ball_state_t& m) { onBallState(m); }, b);
      node.subscribe(
          bus::channels::kTeamState, [this](const team_state_t& m) { onTeamState(m); }, b);
    }
  }

  void onSimWorld(const world_state_t& w) { eval::appendTruth(truth, w); }

  void onRobotState(const robot_state_t& m) {
    eval::StateSample s;
    s.robot = m.header.robot_id;
    s.utime = trueTime(s.robot, m.header.utime, m.header.utime_published);
    s.published = trueTime(s.robot, m.header.utime_published, m.header.utime_published);
    s.x = m.x;
    s.y = m.y;
    s.phi = m.phi;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c)
        s.covariance(r, c) = m.covariance[3 * r + c];
    s.status = m.status;
    s.twin_ambiguous = m.twin_ambiguous != 0;
    states.push_back(s);
    image_to_pose.onState(s.robot, m.header.utime, m.since_vision_us, m.header.utime_published);
  }

  void onLines(const line_contours_t& m) {
    const Utime t = trueTime(m.header.robot_id, m.header.utime, m.header.utime_published);
    first_lines.try_emplace(m.header.robot_id, t);
    last_lines[m.header.robot_id] = t;
    ++lines_count[m.header.robot_id];
  }
  // VISION_LINES per robot (one per camera frame in sim_team): the frame rate the robots got.
  std::map<int, Utime> last_lines;
  std::map<int, std::int64_t> lines_count;

  void onBallState(const ball_state_t& m) {
    eval::BallSample b{m.header.robot_id,
                       trueTime(m.header.robot_id, m.header.utime, m.header.utime_published),
                       m.valid != 0, m.x, m.y};
    b.covariance << m.covariance[0], m.covariance[1], m.covariance[2], m.covariance[3];
    balls.push_back(b);
  }

  void onTeamState(const team_state_t& m) {
    eval::TeamSample t;
    t.robot = m.header.robot_id;
    t.utime = trueTime(t.robot, m.header.utime, m.header.utime_published);
    t.team_ball_valid = m.team_ball_valid;
    t.team_ball_x = m.team_ball_x;
    t.team_ball_y = m.team_ball_y;
    t.team_ball_covariance << m.team_ball_covariance[0], m.team_ball_covariance[1],
        m.team_ball_covariance[2], m.team_ball_covariance[3];
    const eval::TeamBallOptions defaults;
    for (int i = 0; i < m.num_robots && i < 6; ++i) {
      const auto k = static_cast<std::size_t>(i);
      t.sees[k] = m.ball_valid[k] && m.ball_age_us[k] <= defaults.seen_window_us;
    }
    teams.push_back(t);
    onTeamLink(m);
  }

  void onTeamLink(const team_state_t& m) {
    eval::TeamLinkSample l;
    l.robot = m.header.robot_id;
    l.t = static_cast<double>(trueTime(l.robot, m.header.utime, m.header.utime_published)) * 1e-6;
    for (int i = 0; i < m.num_robots && i < 6; ++i) {
      const auto k = static_cast<std::size_t>(i);
      l.present[k] = m.present[k];
      l.pose_t[k] = l.t - static_cast<double>(m.robot_age_us[k]) * 1e-6;
      l.rejected[k] = m.packets_rejected[k];
    }
    team_link.push_back(l);
  }
};

// The command line.
struct EvalArgs {
  std::string scenario = "figure_eight";
  std::string log;
  std::string record_dir;
  std::string launch = "sim_team";
  std::string out_dir;
  std::string field_name;
  double duration = 0.0;
  int robots = 0;
  eval::EvalOptions options;
  std::string log_level = "warn";
  // Faults and load (faults.hpp): --fault, --cpu-hog, --camera-fps.
  std::vector<std::string> faults;
  int cpu_hogs = 0;
  double camera_fps = 0.0;
};

// Faults and load for the robustness scenarios (issue 34 item 3, issue 32 item 2).
void addFaultOptions(cli::App& app, EvalArgs& a) {
  app.add_option("--fault", a.faults,
                 "A fault during the run, seconds after the team started (repeatable): "
                 "restart:PROCESS[/ROBOT]@T (SIGTERM; the launcher restarts it), "
                 "kill:PROCESS[/ROBOT]@T (SIGKILL), stall:ROBOT@T+D or stall:all@T+D (SIGSTOP "
                 "the robot's or every process for D s, then SIGCONT), clockstep:ROBOT@T+S or "
                 "@T-S (the launcher restarts the robot's processes on its clock stepped S s "
                 "ahead or behind, S up to 10). robustness.json and the report give each fault's "
                 "time to recover and largest error while TRACKING; a clock step also when each "
                 "teammate's TEAM_STATE had the robot back")
      ->check([](const std::string& text) {
        try {
          eval::parseFault(text);
          return std::string();
        } catch (const std::invalid_argument& e) {
          return std::string(e.what());
        }
      });
  app.add_option("--cpu-hog", a.cpu_hogs,
                 "Busy loops (one core each) running beside the team for the whole run")
      ->check(cli::Range(0, 4))
      ->capture_default_str();
  app.add_option("--camera-fps", a.camera_fps,
                 "Every camera's frame rate, Hz (the launch file's camera_fps setting; default: "
                 "the camera preset's)")
      ->check(cli::Range(1.0, 240.0));
}

void addOptions(cli::App& app, EvalArgs& a) {
  app.add_option("--scenario", a.scenario, "Scenario preset (config/scenarios) or YAML path")
      ->capture_default_str();
  app.add_option("--log", a.log,
                 "Evaluate a recording instead of running the team: an LCM log with SIM_WORLD and "
                 "ROBOT_STATE (e.g. fieldline-replay --truth's output), or a recording's "
                 "directory (sim.lcm, robot1.lcm, ...); each robot's clock is taken out");
  app.add_option("--record", a.record_dir,
                 "Also record the run (fieldline-record --team) into this directory, to replay "
                 "and evaluate it later with --log");
  app.add_option("--duration", a.duration, "Seconds to run (default: the scenario's, else 30)")
      ->check(cli::Range(3.0, 3600.0));
  app.add_option("--robots", a.robots, "Team size (default: the scenario's highest robot number)")
      ->check(cli::Range(1, 6));
  app.add_option("--launch", a.launch, "Launch file to run the team with")->capture_default_str();
  app.add_option("--out", a.out_dir, "Output directory (default: eval/<scenario or log name>)");
  app.add_option("--field", a.field_name, "Field preset for the plots (default: the scenario's)");
  app.add_option("--settle", a.options.settle_s, "Seconds at the start not scored")
      ->check(cli::Range(0.0, 60.0))
      ->capture_default_str();
  app.add_option("--log-level", a.log_level, "trace, debug, info, warn, error")
      ->capture_default_str();
  addFaultOptions(app, a);
}

// Decodes a checked event of the channels the evaluation reads into the collector.
void dispatch(Collector& collector, const std::string& channel, const void* data, int size) {
  namespace ch = bus::channels;
  const auto as = [&](auto msg, auto handler) {
    if (msg.decode(data, 0, size) == size) handler(msg);
  };
  if (channel == ch::kSimWorld.name) {
    as(world_state_t{}, [&](const world_state_t& m) { collector.onSimWorld(m); });
  } else if (channel == ch::kRobotState.name) {
    as(robot_state_t{}, [&](const robot_state_t& m) { collector.onRobotState(m); });
  } else if (channel == ch::kVisionLines.name) {
    as(line_contours_t{}, [&](const line_contours_t& m) { collector.onLines(m); });
  } else if (channel == ch::kBallState.name) {
    as(ball_state_t{}, [&](const ball_state_t& m) { collector.onBallState(m); });
  } else if (channel == ch::kTeamState.name) {
    as(team_state_t{}, [&](const team_state_t& m) { collector.onTeamState(m); });
  }
}

// Reads a recorded log (or a recording's directory) into the collector; returns the source's
// name. Every robot's stamps are converted to the log's time (the simulator's, where SIM_WORLD
// was recorded on the same machine) with its clock model, fitted to the traffic of its log as
// fieldline-replay fits it: the live evaluation converts with the launch file's clocks.
std::string collectFromLog(EvalArgs& a, Collector& collector) {
  if (!std::filesystem::exists(a.log)) throw std::invalid_argument("no such log: " + a.log);
  if (a.out_dir.empty()) a.out_dir = "eval/" + std::filesystem::path(a.log).stem().string();
  std::filesystem::create_directories(a.out_dir);
  const std::vector<std::string> logs = recording::recordingFiles(a.log);
  // The plots' field: the recording's own (RECORDING_INFO), else msl.
  for (const std::string& path : logs) {
    if (!a.field_name.empty()) break;
    if (const auto info = recording::readRecordingInfo(path); info && !info->field_yaml.empty()) {
      a.field_name = a.out_dir + "/field.yaml";
      std::ofstream(a.field_name) << info->field_yaml;
    }
  }
  if (a.field_name.empty()) a.field_name = "msl";
  for (const std::string& path : logs) {
    // The recording's own clock model (RECORDING_INFO), else one fitted to the file's traffic.
    std::map<int, recording::RobotClockModel> models = recording::estimateClocks(path);
    if (const auto info = recording::readRecordingInfo(path))
      models[info->bus_robot_id] = recording::clockOf(*info);
    for (const auto& [robot, model] : models) {
      if (robot == 0) continue;  // the simulator keeps the true time
      collector.clocks.by_robot[robot] = model.error;
      std::fprintf(stderr, "%s: robot %d's clock: %s\n", path.c_str(), robot,
                   model.describe().c_str());
    }
  }
  std::map<std::string, std::int64_t> rejected;
  std::int64_t read = 0;
  for (const std::string& path : logs) {
    bus::LogReader log(path);
    bus::LogEvent e;
    while (log.nextEvent(e) && !bus::stopSignalReceived()) {
      const void* data = e.data.data();
      const int size = static_cast<int>(e.data.size());
      const auto header = recording::peekHeader(data, size);
      // Checked as a node checks live traffic, "now" being the log time on the sender's clock.
      const ClockError clock = header ? collector.clocks.of(header->robot_id) : ClockError{};
      if (auto r = bus::checkEncoded(e.channel, data, size, truthToOwn(clock, e.timestamp),
                                     500 * kMicrosPerMilli)) {
        if (r->kind == "unknown_channel") continue;
        if (++rejected[r->kind] <= 5) {
          std::fprintf(stderr, "%s: event %lld refused (%s): %s\n", path.c_str(),
                       static_cast<long long>(e.number), r->kind.c_str(), r->text.c_str());
        }
        continue;
      }
      ++read;
      dispatch(collector, e.channel, data, size);
    }
    for (const auto& [kind, n] : log.rejectedByKind())
      rejected[kind] += n;
  }
  std::string kinds;
  for (const auto& [kind, n] : rejected)
    kinds += fmt::format(" {} {}", kind, n);
  std::fprintf(stderr, "%zu log(s): %lld messages read, refused:%s\n", logs.size(),
               static_cast<long long>(read), kinds.empty() ? " none" : kinds.c_str());
  return a.log;
}

// fieldline-record --team for the run's robots into a.record_dir (its output in
// a.out_dir/record.log); -1 when no recording was asked for.
pid_t startRecorder(const EvalArgs& a, const std::string& launch_file) {
  if (a.record_dir.empty()) return -1;
  std::string robot_list;
  for (int r = 1; r <= a.robots; ++r)
    robot_list += (r > 1 ? "," : "") + std::to_string(r);
  const std::string record_log = a.out_dir + "/record.log";
  const std::string record_bin = selfDirectory() + "/fieldline-record";
  const pid_t recorder = fork();
  if (recorder < 0) throw std::runtime_error("fork failed");
  if (recorder == 0) {
    std::FILE* f = std::freopen(record_log.c_str(), "w", stdout);
    if (f) dup2(fileno(stdout), STDERR_FILENO);
    execl(record_bin.c_str(), record_bin.c_str(), "--team", "--robots", robot_list.c_str(),
          "--launch", launch_file.c_str(), "-o", a.record_dir.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  std::fprintf(stderr, "recording into %s (log: %s)\n", a.record_dir.c_str(), record_log.c_str());
  return recorder;
}

// Stops the recorder (SIGINT: it closes its files) and says so when it did not end well.
void stopRecorder(pid_t recorder, const std::string& out_dir) {
  if (recorder <= 0) return;
  kill(recorder, SIGINT);
  int record_status = 0;
  waitpid(recorder, &record_status, 0);
  if (!WIFEXITED(record_status) || WEXITSTATUS(record_status) != 0) {
    std::fprintf(stderr, "recorder ended with status %d (see %s/record.log)\n", record_status,
                 out_dir.c_str());
  }
}

// Ends the busy loops of --cpu-hog.
void stopCpuHogs(const std::vector<pid_t>& hogs) {
  for (const pid_t hog : hogs) {
    if (hog <= 0) continue;
    kill(hog, SIGKILL);
    waitpid(hog, nullptr, 0);
  }
}

// Each clock step the runner made: the robot's new clock joins its clocks (Collector::trueTime).
void noteClockSteps(const std::vector<eval::FaultRecord>& records, Collector& collector) {
  std::size_t steps = 0;
  for (const eval::FaultRecord& r : records) {
    if (r.spec.kind != eval::FaultSpec::Kind::kClockStep || r.processes == 0) continue;
    std::vector<ClockError>& clocks = collector.stepped_clocks[r.spec.robot];
    if (++steps > collector.clock_steps_noted) {
      clocks.push_back(r.clock_after);
      collector.clock_steps_noted = steps;
    }
  }
}

// fieldline-launch for the run (its output into `launch_log`; with `clock_control`, the file of
// the clock steps); returns its pid.
pid_t startLauncher(const EvalArgs& a, const std::string& launch_file,
                    const std::string& launch_log, const std::string& clock_control) {
  const std::string launcher = selfDirectory() + "/fieldline-launch";
  std::vector<std::string> args{launcher,     launch_file,
                                "--robots",   std::to_string(a.robots),
                                "--duration", std::to_string(a.duration),
                                "--no-table"};
  if (!clock_control.empty()) args.insert(args.end(), {"--clock-control", clock_control});
  std::vector<char*> argv;
  for (std::string& arg : args)
    argv.push_back(arg.data());
  argv.push_back(nullptr);
  const pid_t child = fork();
  if (child < 0) throw std::runtime_error("fork failed");
  if (child == 0) {
    std::FILE* f = std::freopen(launch_log.c_str(), "w", stdout);
    if (f) dup2(fileno(stdout), STDERR_FILENO);
    execv(launcher.c_str(), argv.data());
    _exit(127);
  }
  return child;
}

// Runs the team for the scenario through fieldline-launch while collecting; returns the
// source's name.
std::string collectFromTeam(EvalArgs& a, Collector& collector, const Clock& clock) {
  const scenario::Scenario sc = scenario::loadScenarioPreset(a.scenario);
  // Stop before the scenario ends: the simulator would start it over (a jump of every robot
  // that would count as a kidnap).
  if (a.duration <= 0.0) a.duration = sc.duration > 0.0 ? sc.duration - 1.5 : 30.0;
  if (a.robots == 0)
    for (const auto& r : sc.robots)
      a.robots = std::max(a.robots, r.id);
  if (a.field_name.empty()) a.field_name = sc.field;
  if (a.out_dir.empty()) a.out_dir = "eval/" + sc.name;
  std::filesystem::create_directories(a.out_dir);
  if (a.camera_fps > 0.0) {
    // Before scenarioLaunchFile, whose copy of the launch file records the settings.
    const launch::LaunchFile file =
        launch::loadLaunchFile(config::resolvePreset("launch", a.launch));
    if (!file.settings.contains("camera_fps")) {
      throw config::Error(a.launch +
                          ": no `camera_fps` setting for --camera-fps (sim_team.yaml passes it "
                          "to every camera as --fps {camera_fps})");
    }
    setenv(launch::settingVariable("camera_fps").c_str(), fmt::format("{}", a.camera_fps).c_str(),
           1);
  }
  const std::string launch_file = scenarioLaunchFile(a.launch, a.scenario, sc.robot, a.out_dir);
  // The robots' clocks count their drift from this time; the launcher takes it from here.
  const Utime clock_reference = clock.now();
  setenv(kClockReferenceVariable, std::to_string(clock_reference).c_str(), 1);
  collector.clocks = launch::parseRobotClocks(config::Node::loadFile(launch_file), clock_reference);
  const std::string launch_log = a.out_dir + "/launch.log";

  std::vector<eval::FaultSpec> faults;
  for (const std::string& f : a.faults)
    faults.push_back(eval::parseFault(f));
  const eval::ClockStepWiring steps = eval::clockStepWiring(faults, a.out_dir, collector.clocks);
  bus::installStopSignals();
  bus::NodeOptions node_options{.process = "eval", .robot_id = 0, .status_period_us = 0};
  // A robot's clock stepped ahead stamps its messages as from the future: taken all the same.
  node_options.future_tolerance_us += steps.ahead_us;
  bus::Node node(node_options, clock);
  collector.live_clock = &clock;
  std::vector<bus::BusId> buses;
  for (int r = 1; r <= a.robots; ++r)
    buses.push_back(node.addBus(bus::robotBusUrl(r)));
  collector.subscribe(node, bus::kPrimaryBus, buses);

  // The recorder starts before the team and hears everything the evaluation hears.
  const pid_t recorder = startRecorder(a, launch_file);
  const pid_t child = startLauncher(a, launch_file, launch_log, steps.control.path);
  std::fprintf(stderr, "running %s with %d robot(s) for %.0f s (log: %s)\n", sc.name.c_str(),
               a.robots, a.duration, launch_log.c_str());
  eval::FaultRunner fault_runner(child, faults, clock, std::chrono::steady_clock::now(),
                                 steps.control);
  std::vector<pid_t> hogs;
  for (int i = 0; i < a.cpu_hogs; ++i)
    hogs.push_back(eval::startCpuHog(a.duration + 10.0));
  if (a.cpu_hogs > 0) std::fprintf(stderr, "%d CPU hog(s) running\n", a.cpu_hogs);
  int status = 0;
  for (;;) {
    node.spinOnce(faults.empty() ? 50 : 20);
    fault_runner.poll();
    noteClockSteps(fault_runner.records(), collector);
    const pid_t done = waitpid(child, &status, WNOHANG);
    if (done == child) break;
    if (bus::stopSignalReceived()) kill(child, SIGTERM);
  }
  fault_runner.finish();
  collector.faults = fault_runner.records();
  stopCpuHogs(hogs);
  for (int i = 0; i < 10; ++i)
    node.spinOnce(10);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    std::fprintf(stderr, "launcher ended with status %d (see %s)\n", status, launch_log.c_str());
  }
  stopRecorder(recorder, a.out_dir);
  return "scenario " + sc.name;
}

// samples.csv (every matched ROBOT_STATE) and balls.csv (every scored BALL_STATE).
void writeCsvs(const eval::Summary& summary, const std::string& out_dir) {
  std::ofstream csv(out_dir + "/samples.csv");
  csv << "robot,t_s,x,y,phi,true_x,true_y,true_phi,pos_error_m,heading_error_rad,nees,status,"
         "recovering,latency_ms,twin_ambiguous\n";
  for (const eval::Matched& m : summary.matched) {
    csv << fmt::format(
        "{},{:.3f},{:.4f},{:.4f},{:.4f},{:.4f},{:.4f},{:.4f},{:.4f},{:.4f},{:.3f},{},{},{:.2f},{}"
        "\n",
        m.robot, m.t, m.x, m.y, m.phi, m.true_x, m.true_y, m.true_phi, m.pos_error, m.heading_error,
        m.nees, m.status, m.recovering ? 1 : 0, m.latency_ms, m.twin_ambiguous ? 1 : 0);
  }
  std::ofstream balls(out_dir + "/balls.csv");
  balls << "robot,t_s,x,y,true_x,true_y,error_m,range_m\n";
  for (const eval::BallMatched& b : summary.balls) {
    balls << fmt::format("{},{:.3f},{:.4f},{:.4f},{:.4f},{:.4f},{:.4f},{:.3f}\n", b.robot, b.t, b.x,
                         b.y, b.true_x, b.true_y, b.error, b.range);
  }
}

// team_pairs.csv: every robot's TEAM_STATE with its own valid ball, both errors (where the team
// ball loses to an own ball, and when).
void writeTeamPairs(const eval::TeamBallSummary& s, const std::string& out_dir) {
  std::ofstream csv(out_dir + "/team_pairs.csv");
  csv << "robot,utime,own_error_m,team_error_m\n";
  for (const auto& p : s.pairs)
    csv << fmt::format("{},{},{:.4f},{:.4f}\n", p.robot, p.utime, p.own_error_m, p.team_error_m);
}

// The robustness figures (faults.hpp): robustness.json and their lines.
void reportRobustness(const EvalArgs& a, const Collector& collector, const eval::Summary& summary) {
  Utime t0 = 0;
  for (const eval::StateSample& s : collector.states)
    t0 = t0 == 0 ? s.utime : std::min(t0, s.utime);
  std::vector<eval::FaultEvent> events;
  std::map<int, std::size_t> steps_of;  // as noteClockSteps counts them
  for (const eval::FaultRecord& r : collector.faults) {
    eval::FaultEvent& e = events.emplace_back();
    e = {r.spec, static_cast<double>(r.start_utime - t0) * 1e-6,
         static_cast<double>(r.end_utime - t0) * 1e-6, r.processes};
    if (r.spec.kind != eval::FaultSpec::Kind::kClockStep || r.processes == 0) continue;
    const std::size_t step = steps_of[r.spec.robot]++;
    e.new_clock_t = std::numeric_limits<double>::infinity();
    if (const auto robot = collector.first_on_new_clock.find(r.spec.robot);
        robot != collector.first_on_new_clock.end()) {
      if (const auto first = robot->second.find(step); first != robot->second.end())
        e.new_clock_t = static_cast<double>(first->second - t0) * 1e-6;
    }
  }
  std::vector<int> robots;
  for (const auto& [robot, hz] : summary.robot_state_hz)
    robots.push_back(robot);
  std::vector<eval::TeamLinkSample> team = collector.team_link;
  for (eval::TeamLinkSample& l : team) {
    l.t -= static_cast<double>(t0) * 1e-6;
    for (double& p : l.pose_t)
      p -= static_cast<double>(t0) * 1e-6;
  }
  eval::Robustness r = eval::evaluateRobustness(summary, events, robots, {}, team);
  for (const auto& [robot, n] : collector.lines_count) {
    const Utime span = collector.last_lines.at(robot) - collector.first_lines.at(robot);
    if (n > 1 && span > 0) r.vision_lines_hz[robot] = static_cast<double>(n - 1) * 1e6 / span;
  }
  std::ofstream(a.out_dir + "/robustness.json") << eval::robustnessJson(r);
  std::printf("%s\n", eval::robustnessLines(r).c_str());
}

// Scores what was collected, writes the files and prints the summary line(s).
int report(const EvalArgs& a, const Collector& collector, const std::string& source) {
  const eval::Summary summary = eval::evaluate(collector.truth, collector.states, collector.balls,
                                               a.options, collector.first_lines);
  const field::FieldModel field = field::loadFieldPreset(a.field_name);
  const geometry::Vec2 half = field.carpetHalfExtent();
  std::ofstream(a.out_dir + "/summary.json") << eval::summaryJson(summary, source);
  if (!eval::writePlots(summary, a.out_dir, half.x(), half.y())) {
    std::fprintf(stderr, "the plots were not drawn (is gnuplot installed? see %s/plots.log)\n",
                 a.out_dir.c_str());
  }
  writeCsvs(summary, a.out_dir);
  std::fprintf(stderr,
               "%zu truth samples, %zu robot states (%zu scored), %zu ball states; kidnaps %d "
               "(unrecovered %d); latency p50 %.1f ms; output in %s\n",
               collector.truth.size(), summary.states, summary.scored, collector.balls.size(),
               summary.kidnaps, summary.unrecovered, summary.latency_p50_ms, a.out_dir.c_str());
  std::printf("%s\n", eval::summaryLine(summary).c_str());
  std::printf("%s\n", collector.image_to_pose.line().c_str());
  if (summary.states == 0 || collector.truth.empty()) {
    std::fprintf(stderr, "no estimates or no truth to compare\n");
    return 1;
  }
  reportRobustness(a, collector, summary);
  if (!collector.teams.empty()) {
    const eval::TeamBallSummary team_ball =
        eval::evaluateTeamBall(collector.truth, collector.balls, collector.teams);
    std::ofstream(a.out_dir + "/team_ball.json") << eval::teamBallJson(team_ball);
    writeTeamPairs(team_ball, a.out_dir);
    std::printf("%s\n", eval::teamBallLine(team_ball).c_str());
  }
  return 0;
}

int run(EvalArgs a) {
  spdlog::set_level(spdlog::level::from_str(a.log_level));
  if (!a.log.empty() && (!a.faults.empty() || a.cpu_hogs > 0 || a.camera_fps > 0.0))
    throw std::invalid_argument("--fault, --cpu-hog and --camera-fps need a live run, not --log");
  SystemClock clock;
  Collector collector;
  collector.image_to_pose = eval::ImageToPose(a.options.settle_s);
  const std::string source =
      a.log.empty() ? collectFromTeam(a, collector, clock) : collectFromLog(a, collector);
  return report(a, collector, source);
}

}  // namespace

int main(int argc, char** argv) {
  cli::App app{
      "Localization evaluation: runs the simulated team for a scenario (or reads a recorded log "
      "with SIM_WORLD, ROBOT_STATE and BALL_STATE), matches every estimate with the truth at the "
      "same utime, writes summary.json, samples.csv, balls.csv, trajectories.png, errors.png and "
      "latency.png (with TEAM_STATE also team_ball.json and team_pairs.csv: the team ball against "
      "each robot's own ball, over the run and on the same instants), and prints the summary "
      "lines. Run it inside a private network namespace (see docs/fusion.md)."};
  EvalArgs args;
  addOptions(app, args);
  FIELDLINE_PARSE(app, argc, argv);
  recording::installLogUpgrades();
  return bus::runMain("eval", [&]() -> int { return run(args); });
}
