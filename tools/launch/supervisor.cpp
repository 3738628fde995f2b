#include "tools/launch/supervisor.hpp"

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstring>

#include <fcntl.h>
#include <poll.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fmt/format.h>

extern char** environ;

namespace fieldline::launch {
namespace {

// A line longer than this without a newline is passed on in pieces.
constexpr std::size_t kMaxLineBytes = 64 * 1024;

SteadyClock::time_point after(SteadyClock::time_point t, double seconds) {
  return t +
         std::chrono::duration_cast<SteadyClock::duration>(std::chrono::duration<double>(seconds));
}

std::string signalName(int signal) {
  if (const char* abbrev = ::sigabbrev_np(signal)) return std::string("SIG") + abbrev;
  return "signal " + std::to_string(signal);
}

// The child's environment: the launcher's with the instance's entries replacing or added.
std::vector<std::string> childEnvironment(const std::map<std::string, std::string>& extra) {
  std::vector<std::string> env;
  for (char** e = environ; e != nullptr && *e != nullptr; ++e) {
    const std::string_view entry(*e);
    const std::string key(entry.substr(0, entry.find('=')));
    if (!extra.contains(key)) env.emplace_back(entry);
  }
  for (const auto& [key, value] : extra)
    env.push_back(key + "=" + value);
  return env;
}

std::vector<char*> pointers(std::vector<std::string>& words) {
  std::vector<char*> out;
  for (std::string& w : words)
    out.push_back(w.data());
  out.push_back(nullptr);
  return out;
}

// Writes "<prefix><number>\n" with no allocation (runs between fork and exec).
void writeErrno(int fd, const char* prefix, int number) {
  char digits[16];
  int n = 0;
  do {
    digits[n++] = static_cast<char>('0' + number % 10);
    number /= 10;
  } while (number > 0 && n < 15);
  [[maybe_unused]] ssize_t ignored = ::write(fd, prefix, std::strlen(prefix));
  while (n > 0) {
    ignored = ::write(fd, &digits[--n], 1);
  }
  ignored = ::write(fd, "\n", 1);
}

// Runs in the child between fork and exec: only async-signal-safe calls (LCM runs threads in
// the launcher).
[[noreturn]] void execChild(pid_t launcher, int output_fd, const char* path, char* const* argv,
                            char* const* envp, const char* exec_error) {
  ::setpgid(0, 0);
  // Die with the launcher, even when it is killed with SIGKILL; if it already died, go now.
  ::prctl(PR_SET_PDEATHSIG, SIGKILL);
  if (::getppid() != launcher) ::_exit(126);
  sigset_t all;
  sigemptyset(&all);
  ::sigprocmask(SIG_SETMASK, &all, nullptr);
  // The launcher ignores SIGPIPE; an ignored signal would survive exec.
  for (int s : {SIGPIPE, SIGINT, SIGTERM, SIGHUP, SIGCHLD})
    ::signal(s, SIG_DFL);
  const int null_fd = ::open("/dev/null", O_RDONLY);
  if (null_fd >= 0) ::dup2(null_fd, STDIN_FILENO);
  ::dup2(output_fd, STDOUT_FILENO);
  ::dup2(output_fd, STDERR_FILENO);
  // Bus sockets and other children's pipes stay with the launcher.
  ::close_range(3, ~0U, 0);
  ::execve(path, argv, envp);
  writeErrno(STDERR_FILENO, exec_error, errno);
  ::_exit(127);
}

}  // namespace

std::string toString(ProcessState state) {
  switch (state) {
    case ProcessState::kMissing:
      return "missing";
    case ProcessState::kRunning:
      return "running";
    case ProcessState::kWaiting:
      return "waiting";
    case ProcessState::kExited:
      return "exited";
    case ProcessState::kFailed:
      return "failed";
    case ProcessState::kStopped:
      return "stopped";
  }
  return "?";
}

std::string ExitStatus::describe() const {
  return signaled ? "killed by " + signalName(value) : "exit code " + std::to_string(value);
}

ExitStatus exitStatusFromWait(int wait_status) {
  if (WIFSIGNALED(wait_status)) return {true, WTERMSIG(wait_status)};
  return {false, WIFEXITED(wait_status) ? WEXITSTATUS(wait_status) : 1};
}

bool shouldRestart(RestartPolicy policy, const ExitStatus& status) {
  switch (policy) {
    case RestartPolicy::kAlways:
      return true;
    case RestartPolicy::kOnFailure:
      return !status.success();
    case RestartPolicy::kNever:
      return false;
  }
  return false;
}

Supervisor::Supervisor(std::vector<LaunchInstance> instances, SupervisorOptions options,
                       LineHandler on_line, EventHandler on_event)
    : options_(options),
      on_line_(std::move(on_line)),
      on_event_(std::move(on_event)),
      read_buffer_(16 * 1024) {
  // Grandchildren whose parent died are re-parented to us, so we reap them too.
  ::prctl(PR_SET_CHILD_SUBREAPER, 1);
  for (LaunchInstance& instance : instances) {
    ProcessRecord record;
    record.instance = std::move(instance);
    record.backoff = RestartBackoff(options_.backoff);
    records_.push_back(std::move(record));
  }
}

Supervisor::~Supervisor() {
  if (runningCount() > 0) killAll();
  for (ProcessRecord& r : records_) {
    if (r.pid > 0) {
      int status = 0;
      ::waitpid(r.pid, &status, 0);
      r.pid = -1;
    }
    closeOutput(r);
  }
}

void Supervisor::startAll() {
  for (ProcessRecord& r : records_) {
    if (!r.instance.path.empty()) start(r);
  }
}

void Supervisor::start(ProcessRecord& record) {
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) {
    record.last_error = std::string("cannot create a pipe: ") + std::strerror(errno);
    onEnded(record, ExitStatus{false, 127});
    return;
  }
  std::vector<std::string> argv_words = record.instance.argv;
  std::vector<std::string> env_words = childEnvironment(record.instance.env);
  std::vector<char*> argv = pointers(argv_words);
  std::vector<char*> envp = pointers(env_words);
  const std::string exec_error =
      "fieldline-launch: cannot execute " + record.instance.path + ": errno ";
  const pid_t launcher = ::getpid();

  const pid_t pid = ::fork();
  if (pid == 0) {
    execChild(launcher, fds[1], record.instance.path.c_str(), argv.data(), envp.data(),
              exec_error.c_str());
  }
  ::close(fds[1]);
  if (pid < 0) {
    ::close(fds[0]);
    record.last_error = std::string("fork failed: ") + std::strerror(errno);
    on_event_(record.instance.label() + ": " + record.last_error);
    onEnded(record, ExitStatus{false, 127});
    return;
  }
  // Also from this side, so a signal to the group cannot race the child's own setpgid.
  ::setpgid(pid, pid);
  ::fcntl(fds[0], F_SETFL, ::fcntl(fds[0], F_GETFL) | O_NONBLOCK);
  record.pid = pid;
  record.output_fd = fds[0];
  record.partial_line.clear();
  record.state = ProcessState::kRunning;
  record.started = SteadyClock::now();
  on_event_(fmt::format("started {} (pid {})", record.instance.label(), pid));
}

void Supervisor::readOutput(ProcessRecord& record, bool drain) {
  while (record.output_fd >= 0) {
    const ssize_t n = ::read(record.output_fd, read_buffer_.data(), read_buffer_.size());
    if (n > 0) {
      record.partial_line.append(read_buffer_.data(), static_cast<std::size_t>(n));
      std::size_t from = 0;
      for (std::size_t nl = record.partial_line.find('\n', from); nl != std::string::npos;
           nl = record.partial_line.find('\n', from)) {
        std::string_view line(record.partial_line.data() + from, nl - from);
        if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
        on_line_(record, line);
        from = nl + 1;
      }
      record.partial_line.erase(0, from);
      if (record.partial_line.size() >= kMaxLineBytes) flushPartial(record);
      // One buffer per call while running, so a chatty process cannot starve the others.
      if (!drain) return;
      continue;
    }
    if (n < 0 && (errno == EAGAIN || errno == EINTR)) return;
    // End of file (every writer closed it) or a read error.
    closeOutput(record);
  }
}

void Supervisor::flushPartial(ProcessRecord& record) {
  if (record.partial_line.empty()) return;
  on_line_(record, record.partial_line);
  record.partial_line.clear();
}

void Supervisor::closeOutput(ProcessRecord& record) {
  if (record.output_fd < 0) return;
  flushPartial(record);
  ::close(record.output_fd);
  record.output_fd = -1;
}

ProcessRecord* Supervisor::findByPid(pid_t pid) {
  for (ProcessRecord& r : records_) {
    if (r.pid == pid) return &r;
  }
  return nullptr;
}

void Supervisor::reapChildren() {
  for (;;) {
    siginfo_t info{};
    // Look without reaping first: while the zombie exists its process group id cannot be reused,
    // so the group (with anything the process left behind) can be killed safely.
    if (::waitid(P_ALL, 0, &info, WEXITED | WNOHANG | WNOWAIT) != 0 || info.si_pid == 0) return;
    const pid_t pid = info.si_pid;
    ProcessRecord* record = findByPid(pid);
    if (record != nullptr) ::killpg(pid, SIGKILL);
    int wait_status = 0;
    if (::waitpid(pid, &wait_status, 0) != pid) return;
    if (record == nullptr) continue;  // an orphaned grandchild handed to us as subreaper
    record->pid = -1;
    readOutput(*record, /*drain=*/true);
    closeOutput(*record);
    onEnded(*record, exitStatusFromWait(wait_status));
  }
}

void Supervisor::onEnded(ProcessRecord& record, const ExitStatus& status) {
  const auto now = SteadyClock::now();
  const double ran_s = secondsBetween(record.started, now);
  record.last_exit = status;
  const std::string what = fmt::format("{} after {:.1f} s", status.describe(), ran_s);
  if (stopping_) {
    record.state = ProcessState::kStopped;
    on_event_(fmt::format("{} stopped ({})", record.instance.label(), what));
    return;
  }
  if (record.restart_now) {
    record.restart_now = false;
    record.state = ProcessState::kWaiting;
    record.restart_at = now;
    on_event_(fmt::format("{} ended ({}); restarting now", record.instance.label(), what));
    return;
  }
  if (!status.success()) record.last_error = what;
  // Crash loop: this end and the ones before it within the window.
  record.recent_ends.push_back(now);
  const auto window = std::chrono::duration_cast<SteadyClock::duration>(
      std::chrono::duration<double>(options_.crash_loop.window_s));
  while (!record.recent_ends.empty() && now - record.recent_ends.front() > window)
    record.recent_ends.pop_front();
  const bool looping = static_cast<int>(record.recent_ends.size()) >= options_.crash_loop.restarts;
  if (looping && shouldRestart(record.instance.restart, status)) {
    record.crash_loop = true;
    record.state = ProcessState::kFailed;
    record.last_error = fmt::format("crash loop: ended {} times within {:.0f} s, last: {}",
                                    record.recent_ends.size(), options_.crash_loop.window_s, what);
    on_event_(fmt::format("{} FAILED: {}; not restarted again", record.instance.label(),
                          record.last_error));
    return;
  }
  if (shouldRestart(record.instance.restart, status)) {
    const double delay = record.backoff.delayAfterExit(ran_s);
    record.state = ProcessState::kWaiting;
    record.restart_at = after(now, delay);
    on_event_(
        fmt::format("{} ended ({}); restarting in {:.1f} s", record.instance.label(), what, delay));
    return;
  }
  record.state = status.success() ? ProcessState::kExited : ProcessState::kFailed;
  on_event_(fmt::format("{} ended ({}); restart policy {}: not restarted", record.instance.label(),
                        what, toString(record.instance.restart)));
}

void Supervisor::poll(int timeout_ms) {
  auto now = SteadyClock::now();
  // Wake up in time for the next restart or the end of the stop grace period.
  auto wake = after(now, std::max(0, timeout_ms) / 1000.0);
  for (const ProcessRecord& r : records_) {
    if (r.state == ProcessState::kWaiting) wake = std::min(wake, r.restart_at);
    if (r.restart_now && r.pid > 0) wake = std::min(wake, r.restart_kill_at);
  }
  if (stopping_ && !killed_) wake = std::min(wake, kill_deadline_);

  std::vector<pollfd> fds;
  std::vector<std::size_t> owners;
  for (std::size_t i = 0; i < records_.size(); ++i) {
    if (records_[i].output_fd >= 0) {
      fds.push_back(pollfd{records_[i].output_fd, POLLIN, 0});
      owners.push_back(i);
    }
  }
  const auto wait_ms = std::chrono::ceil<std::chrono::milliseconds>(wake - now).count();
  const int ready = ::poll(fds.data(), fds.size(), static_cast<int>(std::max<long>(0, wait_ms)));
  if (ready > 0) {
    for (std::size_t k = 0; k < fds.size(); ++k) {
      if (fds[k].revents != 0) readOutput(records_[owners[k]], /*drain=*/false);
    }
  }
  reapChildren();

  now = SteadyClock::now();
  if (!stopping_) {
    for (ProcessRecord& r : records_) {
      if (r.state == ProcessState::kWaiting && now >= r.restart_at) {
        ++r.restarts;
        start(r);
      } else if (r.restart_now && r.pid > 0 && now >= r.restart_kill_at) {
        on_event_(fmt::format("{} did not stop within {:.1f} s for its restart: SIGKILL",
                              r.instance.label(), options_.stop_grace_s));
        ::killpg(r.pid, SIGKILL);
        r.restart_kill_at = SteadyClock::time_point::max();  // once
      }
    }
  } else if (!killed_ && now >= kill_deadline_ && runningCount() > 0) {
    for (const ProcessRecord& r : records_) {
      if (r.pid > 0) {
        on_event_(fmt::format("{} did not stop within {:.1f} s: SIGKILL", r.instance.label(),
                              options_.stop_grace_s));
      }
    }
    killAll();
  }
}

void Supervisor::requestStop() {
  if (stopping_) return;
  stopping_ = true;
  kill_deadline_ = after(SteadyClock::now(), options_.stop_grace_s);
  for (ProcessRecord& r : records_) {
    if (r.pid > 0) {
      ::killpg(r.pid, SIGTERM);
    } else if (r.state == ProcessState::kWaiting) {
      r.state = ProcessState::kStopped;
    }
  }
}

void Supervisor::killAll() {
  if (!stopping_) requestStop();
  killed_ = true;
  for (const ProcessRecord& r : records_) {
    if (r.pid > 0) ::killpg(r.pid, SIGKILL);
  }
}

int Supervisor::restartRobot(int robot, const std::map<std::string, std::string>& env) {
  int running = 0;
  for (ProcessRecord& r : records_) {
    if (r.instance.robot != robot) continue;
    for (const auto& [key, value] : env)
      r.instance.env[key] = value;
    if (r.pid <= 0 || stopping_) continue;
    r.restart_now = true;
    r.restart_kill_at = after(SteadyClock::now(), options_.stop_grace_s);
    ::killpg(r.pid, SIGTERM);
    ++running;
  }
  return running;
}

bool Supervisor::finished() const {
  return std::none_of(records_.begin(), records_.end(), [](const ProcessRecord& r) {
    return r.state == ProcessState::kRunning || r.state == ProcessState::kWaiting;
  });
}

bool Supervisor::anyFailed() const {
  return std::any_of(records_.begin(), records_.end(),
                     [](const ProcessRecord& r) { return r.state == ProcessState::kFailed; });
}

int Supervisor::runningCount() const {
  return static_cast<int>(std::count_if(records_.begin(), records_.end(),
                                        [](const ProcessRecord& r) { return r.pid > 0; }));
}

}  // namespace fieldline::launch
