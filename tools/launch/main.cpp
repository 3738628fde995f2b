// fieldline-launch: starts the processes a launch file lists, each on its robot's bus, prefixes
// their output, restarts crashed ones with backoff, stops them all on Ctrl-C / SIGTERM and shows
// a live status table fed by SERVICE_STATUS.
#include <atomic>
#include <csignal>
#include <cstdio>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <sys/ioctl.h>
#include <unistd.h>

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>

#include "common/bus/cli.hpp"
#include "common/bus/node.hpp"
#include "common/config/config.hpp"
#include "tools/launch/launch_file.hpp"
#include "tools/launch/plan.hpp"
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

Every process gets `--robot N --bus-url URL --sim-bus-url URL` before its args: robot N's bus is
udpm://GROUP:<base_port+N>, the simulator's udpm://GROUP:<base_port>. An executable that is not
built is skipped with a warning. Output lines are prefixed `[rN name]` (`[sim name]`).
A crashed process is restarted after 0.5 s, 1 s, 2 s ... up to 10 s; a run longer than
stable_s resets the delay. Ctrl-C or SIGTERM stops everything (a second Ctrl-C kills at once).

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

void onLauncherStopSignal(int) {
  g_stop_signals.fetch_add(1);
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

struct Options {
  std::string launch_file = "sim_team";
  std::optional<int> robots;
  double duration_s = 0;
  bool no_table = false;
  bool dry_run = false;
  double status_period_s = 5;
};

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

int printDryRun(const LaunchPlan& plan) {
  for (const std::string& note : plan.notes)
    std::printf("# %s\n", note.c_str());
  for (const LaunchInstance& i : plan.instances) {
    std::string env;
    for (const auto& [k, v] : i.env)
      env += commandText({k + "=" + v}) + " ";
    // Skipped instances are shown commented out, so the output stays a runnable script.
    std::printf("# [%s] restart %s%s\n%s%s\n", i.label().c_str(), toString(i.restart).c_str(),
                i.path.empty() ? ", NOT BUILT: skipped" : "", i.path.empty() ? "# " : "",
                (env + commandText(i.argv)).c_str());
  }
  return 0;
}

// The status feed: a node listening to SERVICE_STATUS on every bus the team uses.
std::unique_ptr<bus::Node> openStatusFeed(const std::vector<LaunchInstance>& instances,
                                          const Clock& clock, StatusBoard& board,
                                          Console& console) {
  std::map<int, std::string> buses;
  for (const LaunchInstance& i : instances) {
    if (!i.path.empty()) buses.emplace(i.robot, i.bus_url);
  }
  if (buses.empty()) return nullptr;
  try {
    auto node = std::make_unique<bus::Node>(bus::NodeOptions{.process = "launch",
                                                             .robot_id = 0,
                                                             .url = buses.begin()->second,
                                                             .status_period_us = 0},
                                            clock);
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

int runLauncher(const Options& options) {
  const std::string path = config::resolvePreset("launch", options.launch_file);
  const LaunchFile file = loadLaunchFile(path);
  const int team_size = options.robots.value_or(file.defaults.robots);
  const std::string bin_dir = selfDirectory();
  const char* search_path = std::getenv("PATH");
  const LaunchPlan plan = planLaunch(file, team_size, [&](const std::string& executable) {
    return findExecutable(executable, bin_dir, search_path);
  });
  if (options.dry_run) return printDryRun(plan);

  const bool live_table = !options.no_table && ::isatty(STDOUT_FILENO) != 0 &&
                          std::string(std::getenv("TERM") ? std::getenv("TERM") : "") != "dumb";
  Console console(live_table);
  console.line(fmt::format("[launch] {}: {} processes for {} robots", path, plan.instances.size(),
                           team_size));
  for (const std::string& note : plan.notes)
    console.line("[launch] " + note);
  warnMissing(plan.instances, bin_dir, console);
  const bool runnable = std::any_of(plan.instances.begin(), plan.instances.end(),
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
  std::unique_ptr<bus::Node> feed = openStatusFeed(plan.instances, clock, board, console);

  const bool colour = live_table;
  Supervisor supervisor(
      plan.instances,
      SupervisorOptions{.backoff = file.defaults.backoff,
                        .stop_grace_s = file.defaults.stop_grace_s},
      [&](const ProcessRecord& r, std::string_view text) {
        const std::string prefix = "[" + r.instance.label() + "]";
        console.line(colour ? fmt::format("\x1b[36m{}\x1b[0m {}", prefix, text)
                            : fmt::format("{} {}", prefix, text));
      },
      [&](const std::string& event) { console.line("[launch] " + event); });
  supervisor.startAll();

  const auto started = SteadyClock::now();
  auto next_report = started;
  bool stopped_on_request = false;
  int signals_handled = 0;
  while (!supervisor.finished()) {
    const int signals = g_stop_signals.load();
    if (signals > signals_handled) {
      signals_handled = signals;
      stopped_on_request = true;
      if (!supervisor.stopping()) {
        console.line("[launch] stopping: SIGTERM to every process (Ctrl-C again to kill)");
        supervisor.requestStop();
      } else {
        console.line("[launch] killing every process");
        supervisor.killAll();
      }
    }
    const auto now = SteadyClock::now();
    if (options.duration_s > 0 && !supervisor.stopping() &&
        now - started >= std::chrono::duration<double>(options.duration_s)) {
      stopped_on_request = true;
      console.line(fmt::format("[launch] {:.1f} s are over: stopping", options.duration_s));
      supervisor.requestStop();
    }
    supervisor.poll(50);
    if (feed) feed->spinOnce(0);

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
        next_report =
            now + std::chrono::duration_cast<SteadyClock::duration>(
                      std::chrono::duration<double>(std::max(0.2, options.status_period_s)));
      }
    }
    console.flush(nullptr);
  }
  const auto rows = board.rows(supervisor.processes(), false, SteadyClock::now());
  const bool failed = !stopped_on_request && supervisor.anyFailed();
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
  return failed ? 1 : 0;
}

}  // namespace
}  // namespace fieldline::launch

int main(int argc, char** argv) {
  using namespace fieldline::launch;
  Options options;
  CLI::App app{
      "fieldline-launch: starts the processes of a launch file, each on its robot's LCM bus; "
      "prefixes their output with [robot process], restarts crashed ones with backoff, stops "
      "all of them on Ctrl-C or SIGTERM and shows a live status table from SERVICE_STATUS."};
  app.add_option("launch_file", options.launch_file,
                 "Launch file: a path, or a preset name in config/launch/")
      ->capture_default_str();
  app.add_option("--robots", options.robots,
                 "Team size: `all` means robots 1..N (default: defaults.robots of the file)")
      ->check(CLI::Range(1, kMaxRobot));
  app.add_option("--duration", options.duration_s,
                 "Run this many seconds, then stop everything cleanly and exit 0 (0: until "
                 "Ctrl-C)")
      ->check(CLI::Range(0.0, 1e7))
      ->capture_default_str();
  app.add_flag("--no-table", options.no_table,
               "Plain log output (for CI): compact status lines instead of the live table");
  app.add_flag("--dry-run", options.dry_run, "Print the command lines and exit");
  app.add_option("--status-period", options.status_period_s,
                 "Seconds between compact status lines when there is no live table")
      ->check(CLI::Range(0.2, 3600.0))
      ->capture_default_str();
  app.footer(kFormatHelp);
  FIELDLINE_PARSE(app, argc, argv);
  return fieldline::bus::runMain("fieldline-launch", [&] { return runLauncher(options); });
}
