#include "tools/launch/launcher.hpp"

#include <algorithm>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <sys/ioctl.h>
#include <unistd.h>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "common/bus/node.hpp"
#include "common/config/config.hpp"
#include "tools/launch/bus_route.hpp"
#include "tools/launch/graph.hpp"
#include "tools/launch/preflight.hpp"
#include "tools/launch/robot_clocks.hpp"
#include "tools/launch/status_board.hpp"
#include "tools/launch/supervisor.hpp"

namespace fieldline::launch {
namespace {

constexpr const char* kFormatHelp = R"(
LAUNCH FILE (YAML; a preset name like `sim_team` means config/launch/sim_team.yaml)

  defaults:                      # optional, every key optional
    robots: 6                    # team size: `robots: all` means 1..6 (--robots overrides)
    restart: on-failure          # always | on-failure | never
    stop_grace_s: 3.0            # SIGTERM, then SIGKILL after this many seconds
    backoff: {initial_s: 0.5, max_s: 10.0, stable_s: 60.0}
    crash_loop: {restarts: 5, window_s: 30.0}   # ends within window_s: failed, not restarted
    bus: {group: 239.255.76.67, base_port: 7667, ttl: 0, recv_buf_size: 4194304}
  processes:
    - name: world_sim            # unique; letters, digits, _ and -
      executable: fieldline-world-sim
      robots: sim                # sim (= 0, one team-wide process) | all | N | [1, 3]
      restart: always
    - name: camera
      executable: fieldline-camera   # looked up next to fieldline-launch, then in PATH
      robots: all
      args: [--source, sim, --config, camera_r{robot}]   # {robot} -> robot number
      env: {OMP_NUM_THREADS: "1"}
      main_channel: CAMERA_IMAGE # channel shown in the status table (default: busiest output)
      optional: true             # skip with a warning when not built (default: an error)

Every process gets `--robot N --bus-url URL --sim-bus-url URL` before its args: robot N's bus is
udpm://GROUP:<base_port+N>, the simulator's udpm://GROUP:<base_port>. Output lines are prefixed
`[rN name]` (`[sim name]`).

WATCHING FROM ANOTHER MACHINE: `bus: {ttl: 1, interface: wlan0}` in defaults (or --bus-ttl 1
--bus-interface wlan0) lets the buses leave through wlan0, so fieldline-viewer --no-sim and
lcm-spy on a laptop see them; the multicast route must name that interface (checked before the
start, with the fix). The camera's full frames stay on the robot; CAMERA_PREVIEW goes out.

CHECKS (before anything starts, and all that --dry-run does): the multicast group and ports; every
executable exists (a name not found is an error with the closest built name, unless the entry says
`optional: true`); every child accepts its command line, run once with --check-args (parses its
arguments and configuration, exits 0 or 2, starts nothing). Any problem: exit code 2.

A crashed process is restarted after 0.5 s, 1 s, 2 s ... up to 10 s; a run longer than
stable_s resets the delay. A process that ends crash_loop.restarts times within window_s is
crash-looping: not restarted again, `failed` in the table, and the launcher's exit code is 1 (also
after --duration or Ctrl-C). Ctrl-C or SIGTERM stops everything (a second Ctrl-C kills at once).

STATUS TABLE (from SERVICE_STATUS on every bus): robot, process, state (ok/warn/error as the
process reports; starting, stale, waiting for restart, failed, missing...), main output channel
with its rate, latency p50/p95 (utime_published - utime), processing p95, input drops, errors,
restarts, last error. Redrawn every second on a terminal; otherwise (or with --no-table) a
compact status line every --status-period seconds.

EXAMPLES
  fieldline-launch                          # the simulated team, config/launch/sim_team.yaml
  fieldline-launch sim_team --robots 2 --duration 10 --no-table
  fieldline-launch config/launch/real_robot.yaml --dry-run
)";

std::atomic<int> g_stop_signals{0};
std::atomic<int> g_clock_signals{0};

void onLauncherStopSignal(int) {
  g_stop_signals.fetch_add(1);
}

void onClockControlSignal(int) {
  g_clock_signals.fetch_add(1);
}

// SIGUSR1 (apply the --clock-control file) is caught from the start, so an early one is kept for
// the supervision rather than ending the launcher (its default action).
void installClockControlSignal() {
  struct sigaction sa {};
  sa.sa_handler = onClockControlSignal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGUSR1, &sa, nullptr);
}

void installSignals() {
  struct sigaction sa {};
  sa.sa_handler = onLauncherStopSignal;
  sigemptyset(&sa.sa_mask);
  // No SA_RESTART: poll() returns at once so the stop begins without delay.
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  sigaction(SIGHUP, &sa, nullptr);
  // Writing to a closed pipe (launcher | head) must not kill the launcher before it stops
  // its children.
  std::signal(SIGPIPE, SIG_IGN);
}

int terminalWidth() {
  winsize ws{};
  if (::ioctl(STDOUT_FILENO, TIOCGWINSZ, &ws) == 0 && ws.ws_col > 0) return ws.ws_col;
  return 120;
}

int terminalHeight() {
  winsize ws{};
  if (::ioctl(STDOUT_FILENO, TIOCGWINSZ, &ws) == 0 && ws.ws_row > 0) return ws.ws_row;
  return 40;
}

// Everything the launcher prints goes through here, so the live table stays below the log.
class Console {
 public:
  explicit Console(bool live_table) : live_table_(live_table) {}

  void line(const std::string& text) { pending_.push_back(text); }

  // Prints pending lines; in table mode erases the table first and draws `table` after them.
  void flush(const std::vector<std::string>* table) {
    if (pending_.empty() && table == nullptr) return;
    std::string out;
    if (live_table_ && drawn_lines_ > 0) {
      // Back to the table's first line, then erase to the end of the screen.
      out += fmt::format("\x1b[{}F\x1b[J", drawn_lines_);
      drawn_lines_ = 0;
    }
    for (const std::string& l : pending_) {
      out += l;
      out += '\n';
    }
    pending_.clear();
    if (live_table_) {
      if (table != nullptr) last_table_ = *table;
      for (const std::string& l : last_table_) {
        out += l;
        out += '\n';
      }
      drawn_lines_ = static_cast<int>(last_table_.size());
    }
    std::fwrite(out.data(), 1, out.size(), stdout);
    std::fflush(stdout);
  }

  bool hasPending() const { return !pending_.empty(); }

 private:
  bool live_table_;
  std::vector<std::string> pending_;
  std::vector<std::string> last_table_;
  int drawn_lines_ = 0;
};

// Table lines fitted to the terminal: rows that do not fit are summarised in one line.
std::vector<std::string> fittedTable(const std::vector<StatusRow>& rows) {
  std::vector<std::string> lines = renderTable(rows, terminalWidth() - 1, true);
  const std::size_t max_lines = static_cast<std::size_t>(std::max(4, terminalHeight() / 2));
  if (lines.size() > max_lines) {
    const std::size_t hidden = lines.size() - (max_lines - 1);
    lines.resize(max_lines - 1);
    lines.push_back(fmt::format("... {} more processes (enlarge the terminal)", hidden));
  }
  return lines;
}

// Warns once per executable that is not built, naming the robots it was meant for.
void warnMissing(const std::vector<LaunchInstance>& instances, const std::string& bin_dir,
                 Console& console) {
  std::map<std::string, std::vector<std::string>> missing;
  for (const LaunchInstance& i : instances) {
    if (i.path.empty()) missing[i.executable].push_back(i.label());
  }
  for (const auto& [executable, labels] : missing) {
    std::string who;
    for (const std::string& l : labels)
      who += (who.empty() ? "" : ", ") + l;
    console.line(
        fmt::format("[launch] warning: {} is not built (looked in {} and PATH): skipping {}",
                    executable, bin_dir, who));
  }
}

// The status feed: a node listening to SERVICE_STATUS on every bus the team uses.
// `ahead_us`: how far ahead of the true time a robot's clock may be (clock steps).
std::unique_ptr<bus::Node> openStatusFeed(const std::vector<LaunchInstance>& instances,
                                          const Clock& clock, StatusBoard& board, Console& console,
                                          Utime ahead_us) {
  std::map<int, std::string> buses;
  for (const LaunchInstance& i : instances) {
    if (!i.path.empty()) buses.emplace(i.robot, i.bus_url);
  }
  if (buses.empty()) return nullptr;
  try {
    bus::NodeOptions options{
        .process = "launch", .robot_id = 0, .url = buses.begin()->second, .status_period_us = 0};
    options.future_tolerance_us += ahead_us;
    auto node = std::make_unique<bus::Node>(options, clock);
    for (const auto& [robot, url] : buses) {
      const bus::BusId id = url == buses.begin()->second ? bus::kPrimaryBus : node->addBus(url);
      node->subscribe(
          bus::channels::kServiceStatus,
          [&board, robot = robot](const service_status_t& s) {
            board.onStatus(robot, s, SteadyClock::now());
          },
          id);
    }
    return node;
  } catch (const bus::BusError& e) {
    console.line(fmt::format("[launch] warning: no status table: {}", e.what()));
    return nullptr;
  }
}

}  // namespace

const char* launchFileHelp() {
  return kFormatHelp;
}

Launcher::Launcher(LauncherOptions options) : options_(std::move(options)) {}

void Launcher::addPlanHook(PlanHook hook) {
  hooks_.push_back(std::move(hook));
}

void Launcher::plan() {
  path_ = config::resolvePreset("launch", options_.launch_file);
  file_ = loadLaunchFile(path_, LaunchOverrides{.settings = options_.settings,
                                                .robot = options_.robot,
                                                .environment = processEnvironment,
                                                .bus_ttl = options_.bus_ttl,
                                                .bus_interface = options_.bus_interface});
  team_size_ = options_.robots.value_or(file_.defaults.robots);
  bin_dir_ = selfDirectory();
  const char* search_path = std::getenv("PATH");
  plan_ = planLaunch(file_, team_size_, [&](const std::string& executable) {
    return findExecutable(executable, bin_dir_, search_path);
  });
  for (const PlanHook& hook : hooks_)
    hook(file_, plan_);
  if (file_.defaults.bus.ttl > 0) {
    const RouteLookup route =
        multicastRoute(file_.defaults.bus.group, file_.defaults.bus.base_port);
    plan_.notes.push_back(fmt::format(
        "the buses leave this machine (ttl {}) through {}: another machine on that network may "
        "watch them (CAMERA_IMAGE stays here; CAMERA_PREVIEW goes out)",
        file_.defaults.bus.ttl,
        route.interface.empty() ? "no interface (" + route.error + ")" : route.interface));
  }
}

std::vector<std::string> Launcher::preflight() const {
  std::vector<std::string> problems = checkExecutables(file_, plan_, bin_dir_);
  if (file_.defaults.bus.ttl > 0) {
    // Buses meant for another machine must leave through the interface the file names.
    if (std::string route = checkBusRoute(file_.defaults.bus, file_.defaults.bus_interface);
        !route.empty()) {
      problems.push_back(file_.path + ": defaults.bus: " + route);
    }
  }
  if (options_.dry_run) {
    // Every instance: arguments can differ per robot ({robot} in a preset name).
    for (std::string& p : checkArguments(plan_.instances))
      problems.push_back(std::move(p));
  } else if (options_.check_args) {
    // Before a start, one instance per entry (its first robot) catches a typo in the entry's
    // arguments without delaying the team by a check of every robot.
    std::vector<LaunchInstance> firsts;
    std::set<std::string> seen;
    for (const LaunchInstance& i : plan_.instances) {
      if (seen.insert(i.name).second) firsts.push_back(i);
    }
    for (std::string& p : checkArguments(firsts))
      problems.push_back(std::move(p));
  }
  return problems;
}

int Launcher::printDryRun(const std::vector<std::string>& problems) const {
  if (!file_.include_path.empty()) std::printf("# include: %s\n", file_.include_path.c_str());
  for (const auto& [name, setting] : file_.settings) {
    std::printf("# setting %s = %s (%s; %s or --set %s=...)\n", name.c_str(), setting.value.c_str(),
                setting.origin.c_str(), settingVariable(name).c_str(), name.c_str());
  }
  for (const std::string& note : plan_.notes)
    std::printf("# %s\n", note.c_str());
  for (const LaunchInstance& i : plan_.instances) {
    std::string env;
    for (const auto& [k, v] : i.env)
      env += commandText({k + "=" + v}) + " ";
    // Skipped instances are shown commented out, so the output stays a runnable script.
    std::printf("# [%s] restart %s%s\n%s%s\n", i.label().c_str(), toString(i.restart).c_str(),
                i.path.empty() ? ", NOT BUILT: skipped" : "", i.path.empty() ? "# " : "",
                (env + commandText(i.argv)).c_str());
  }
  std::fflush(stdout);
  for (const std::string& p : problems)
    std::fprintf(stderr, "fieldline-launch: error: %s\n", p.c_str());
  if (!problems.empty()) {
    std::fprintf(stderr, "fieldline-launch: %zu problem(s) in %s: nothing would start\n",
                 problems.size(), path_.c_str());
    return kExitBadLaunch;
  }
  return 0;
}

int Launcher::run() {
  installClockControlSignal();
  plan();
  if (options_.graph) return printGraph();
  const std::vector<std::string> problems = preflight();
  if (options_.dry_run) return printDryRun(problems);
  if (!problems.empty()) {
    for (const std::string& p : problems)
      std::fprintf(stderr, "[launch] error: %s\n", p.c_str());
    std::fprintf(stderr, "[launch] %zu problem(s) in %s: nothing started (see --dry-run)\n",
                 problems.size(), path_.c_str());
    return kExitBadLaunch;
  }
  return supervise();
}

int Launcher::printGraph() const {
  std::vector<std::string> problems = checkExecutables(file_, plan_, bin_dir_);
  // Nothing starts, so a loaded machine may take its time (a camera loads OpenCV and GStreamer).
  const LaunchGraph graph = queryGraph(plan_, {.timeout_s = 120.0, .parallel = 4});
  problems.insert(problems.end(), graph.problems.begin(), graph.problems.end());
  std::printf("# %s: %zu processes for %d robots\n", path_.c_str(), plan_.instances.size(),
              team_size_);
  for (const std::string& s : graph.skipped)
    std::printf("# %s: not built, left out\n", s.c_str());
  std::printf("%s", formatGraph(graph.nodes).c_str());
  std::fflush(stdout);
  for (const std::string& p : problems)
    std::fprintf(stderr, "fieldline-launch: error: %s\n", p.c_str());
  if (!problems.empty()) return kExitBadLaunch;
  return missingWriters(graph.nodes).empty() ? 0 : kExitProcessFailed;
}

namespace {

// A Ctrl-C or SIGTERM: the first stops every process, the next kills them.
void handleSignals(Supervisor& supervisor, Console& console, int& signals_handled) {
  const int signals = g_stop_signals.load();
  if (signals > signals_handled) {
    signals_handled = signals;
    if (!supervisor.stopping()) {
      console.line("[launch] stopping: SIGTERM to every process (Ctrl-C again to kill)");
      supervisor.requestStop();
    } else {
      console.line("[launch] killing every process");
      supervisor.killAll();
    }
  }
}

// A SIGUSR1: the --clock-control file's offsets; every robot whose clock they change is restarted
// on its new clock. A bad file is reported and changes nothing.
void applyClockControl(const std::string& path, Supervisor& supervisor, Console& console,
                       int& signals_handled) {
  const int signals = g_clock_signals.load();
  if (signals <= signals_handled) return;
  signals_handled = signals;
  if (path.empty()) {
    console.line("[launch] warning: SIGUSR1 without --clock-control: ignored");
    return;
  }
  std::map<int, Utime> offsets;
  try {
    std::ifstream in(path);
    if (!in) throw config::Error(path + ": cannot be read");
    std::ostringstream text;
    text << in.rdbuf();
    offsets = parseClockControl(text.str(), path);
  } catch (const config::Error& e) {
    console.line(fmt::format("[launch] error: clock control: {}; no clock changed", e.what()));
    return;
  }
  for (const auto& [robot_id, offset_us] : offsets) {
    // A copy: clang 14 cannot capture a structured binding in a lambda.
    const int robot = robot_id;
    const std::string value = std::to_string(offset_us);
    const auto current = [&]() -> std::string {
      for (const ProcessRecord& r : supervisor.processes()) {
        if (r.instance.robot != robot) continue;
        const auto it = r.instance.env.find(kClockOffsetVariable);
        return it == r.instance.env.end() ? "0" : it->second;
      }
      return value;  // no process of that robot: nothing to change
    }();
    if (current == value) continue;
    const int restarted = supervisor.restartRobot(robot, {{kClockOffsetVariable, value}});
    console.line(
        fmt::format("[launch] {}'s clock stepped to {:+.6f} s: restarting its {} process(es)",
                    robotLabel(robot), static_cast<double>(offset_us) * 1e-6, restarted));
  }
}

// The status: the live table, or a compact line every status period.
void reportStatus(const StatusBoard& board, const Supervisor& supervisor, Console& console,
                  bool live_table, double status_period_s, SteadyClock::time_point now,
                  SteadyClock::time_point& next_report) {
  // The live table is redrawn every second, and with fresh contents whenever log lines push
  // it down anyway.
  if (SteadyClock::now() >= next_report || (live_table && console.hasPending())) {
    const auto rows = board.rows(supervisor.processes(), supervisor.stopping(), now);
    if (live_table) {
      const auto table = fittedTable(rows);
      console.flush(&table);
      if (SteadyClock::now() >= next_report) next_report = now + std::chrono::seconds(1);
    } else {
      console.line("[launch] status: " + renderCompact(rows));
      next_report = now + std::chrono::duration_cast<SteadyClock::duration>(
                              std::chrono::duration<double>(std::max(0.2, status_period_s)));
    }
  }
}

// The final status; the exit code of the run.
int finishRun(const StatusBoard& board, const Supervisor& supervisor, Console& console,
              bool live_table) {
  const auto rows = board.rows(supervisor.processes(), false, SteadyClock::now());
  // A crash loop or a failure that was not restarted is a failed run, also when the run was
  // ended by --duration or a signal.
  const bool failed = supervisor.anyFailed();
  if (live_table) {
    console.line(failed ? "[launch] done: a process failed" : "[launch] done");
    // The final table stays on screen, below the last log line.
    const auto table = fittedTable(rows);
    console.flush(&table);
  } else {
    console.line("[launch] final: " + renderCompact(rows));
    console.line(failed ? "[launch] done: a process failed" : "[launch] done");
    console.flush(nullptr);
  }
  return failed ? kExitProcessFailed : 0;
}

}  // namespace

int Launcher::supervise() {
  const bool live_table = !options_.no_table && ::isatty(STDOUT_FILENO) != 0 &&
                          std::string(std::getenv("TERM") ? std::getenv("TERM") : "") != "dumb";
  Console console(live_table);
  console.line(fmt::format("[launch] {}: {} processes for {} robots", path_, plan_.instances.size(),
                           team_size_));
  for (const std::string& note : plan_.notes)
    console.line("[launch] " + note);
  warnMissing(plan_.instances, bin_dir_, console);
  const bool runnable = std::any_of(plan_.instances.begin(), plan_.instances.end(),
                                    [](const LaunchInstance& i) { return !i.path.empty(); });
  if (!runnable) {
    console.line("[launch] warning: nothing to run: none of the listed executables is built");
    console.flush(nullptr);
    return 0;
  }

  installSignals();
  // The bus layer logs through spdlog; keep its lines in the launcher's format.
  spdlog::set_pattern("[launch] %l: %v");
  spdlog::set_level(spdlog::level::warn);
  SystemClock clock;
  StatusBoard board;
  const Utime ahead_us = options_.clock_control.empty()
                             ? 0
                             : static_cast<Utime>(kMaxControlledOffsetS * kMicrosPerSecond);
  std::unique_ptr<bus::Node> feed =
      openStatusFeed(plan_.instances, clock, board, console, ahead_us);

  const bool colour = live_table;
  Supervisor supervisor(
      plan_.instances,
      SupervisorOptions{.backoff = file_.defaults.backoff,
                        .stop_grace_s = file_.defaults.stop_grace_s,
                        .crash_loop = file_.defaults.crash_loop},
      [&](const ProcessRecord& r, std::string_view text) {
        const std::string prefix = "[" + r.instance.label() + "]";
        console.line(colour ? fmt::format("\x1b[36m{}\x1b[0m {}", prefix, text)
                            : fmt::format("{} {}", prefix, text));
      },
      [&](const std::string& event) { console.line("[launch] " + event); });
  supervisor.startAll();

  const auto started = SteadyClock::now();
  auto next_report = started;
  int signals_handled = 0;
  int clock_signals_handled = 0;
  while (!supervisor.finished()) {
    handleSignals(supervisor, console, signals_handled);
    applyClockControl(options_.clock_control, supervisor, console, clock_signals_handled);
    const auto now = SteadyClock::now();
    if (options_.duration_s > 0 && !supervisor.stopping() &&
        now - started >= std::chrono::duration<double>(options_.duration_s)) {
      console.line(fmt::format("[launch] {:.1f} s are over: stopping", options_.duration_s));
      supervisor.requestStop();
    }
    supervisor.poll(50);
    if (feed) feed->spinOnce(0);

    reportStatus(board, supervisor, console, live_table, options_.status_period_s, now,
                 next_report);
    console.flush(nullptr);
  }
  return finishRun(board, supervisor, console, live_table);
}

}  // namespace fieldline::launch
