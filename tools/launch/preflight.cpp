#include "tools/launch/preflight.hpp"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <map>
#include <set>

#include <fcntl.h>
#include <poll.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fmt/format.h>

#include "common/config/closest.hpp"

extern char** environ;

namespace fieldline::launch {
namespace {

using PreflightClock = std::chrono::steady_clock;

// Output kept per check: its end is what explains a failure.
constexpr std::size_t kMaxOutputBytes = 16 * 1024;

// Names of the fieldline executables next to the launcher, for "did you mean".
std::vector<std::string> builtExecutables(const std::string& bin_dir) {
  std::vector<std::string> names;
  std::error_code ec;
  if (bin_dir.empty()) return names;
  for (const auto& entry : std::filesystem::directory_iterator(bin_dir, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.starts_with("fieldline-") && ::access(entry.path().c_str(), X_OK) == 0) {
      names.push_back(name);
    }
  }
  std::sort(names.begin(), names.end());
  return names;
}

// The last `count` non-empty lines of `text`, joined by " | ".
std::string lastLines(const std::string& text, std::size_t count) {
  std::vector<std::string> lines;
  std::size_t from = 0;
  while (from < text.size()) {
    std::size_t end = text.find('\n', from);
    if (end == std::string::npos) end = text.size();
    if (end > from) lines.push_back(text.substr(from, end - from));
    from = end + 1;
  }
  std::string out;
  for (std::size_t i = lines.size() > count ? lines.size() - count : 0; i < lines.size(); ++i)
    out += (out.empty() ? "" : " | ") + lines[i];
  return out.empty() ? "(no output)" : out;
}

struct Check {
  const LaunchInstance* instance = nullptr;
  pid_t pid = -1;
  int fd = -1;
  std::string output;
  PreflightClock::time_point deadline;
  bool timed_out = false;
};

// Starts `instance` with `option` appended; output (stdout and stderr) into a pipe.
Check startCheck(const LaunchInstance& instance, const char* option, double timeout_s) {
  Check check;
  check.instance = &instance;
  std::vector<std::string> words = instance.argv;
  words.emplace_back(option);
  std::vector<char*> argv;
  for (std::string& w : words)
    argv.push_back(w.data());
  argv.push_back(nullptr);
  std::vector<std::string> env_words;
  for (char** e = environ; e != nullptr && *e != nullptr; ++e) {
    const std::string entry(*e);
    if (!instance.env.contains(entry.substr(0, entry.find('=')))) env_words.push_back(entry);
  }
  for (const auto& [key, value] : instance.env)
    env_words.push_back(key + "=" + value);
  std::vector<char*> envp;
  for (std::string& w : env_words)
    envp.push_back(w.data());
  envp.push_back(nullptr);

  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) {
    check.output = std::string("pipe failed: ") + std::strerror(errno);
    return check;
  }
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::setpgid(0, 0);
    const int null_fd = ::open("/dev/null", O_RDONLY);
    if (null_fd >= 0) ::dup2(null_fd, STDIN_FILENO);
    ::dup2(fds[1], STDOUT_FILENO);
    ::dup2(fds[1], STDERR_FILENO);
    ::close_range(3, ~0U, 0);
    for (int s : {SIGPIPE, SIGINT, SIGTERM, SIGHUP, SIGCHLD})
      ::signal(s, SIG_DFL);
    ::execve(instance.path.c_str(), argv.data(), envp.data());
    constexpr const char kMessage[] = "cannot execute the program\n";
    [[maybe_unused]] const ssize_t ignored = ::write(STDERR_FILENO, kMessage, sizeof kMessage - 1);
    ::_exit(127);
  }
  ::close(fds[1]);
  if (pid < 0) {
    ::close(fds[0]);
    check.output = std::string("fork failed: ") + std::strerror(errno);
    return check;
  }
  ::setpgid(pid, pid);
  ::fcntl(fds[0], F_SETFL, ::fcntl(fds[0], F_GETFL) | O_NONBLOCK);
  check.pid = pid;
  check.fd = fds[0];
  check.deadline = PreflightClock::now() + std::chrono::duration_cast<PreflightClock::duration>(
                                               std::chrono::duration<double>(timeout_s));
  return check;
}

void readAvailable(Check& check) {
  char buffer[4096];
  while (check.fd >= 0) {
    const ssize_t n = ::read(check.fd, buffer, sizeof buffer);
    if (n > 0) {
      check.output.append(buffer, static_cast<std::size_t>(n));
      if (check.output.size() > kMaxOutputBytes) {
        check.output.erase(0, check.output.size() - kMaxOutputBytes);
      }
      continue;
    }
    if (n < 0 && (errno == EAGAIN || errno == EINTR)) return;
    ::close(check.fd);
    check.fd = -1;
  }
}

// The problem a finished check reports, or "" when the arguments were accepted.
std::string verdict(const LaunchInstance& instance, const ChildAnswer& check) {
  const std::string who = instance.label();
  const std::string output = lastLines(check.output, 3);
  const int wait_status = check.wait_status;
  if (check.failed_to_start) return who + ": " + check.output;
  if (check.timed_out) {
    return fmt::format(
        "{}: no answer to {} within the time limit (does it start instead of "
        "checking?): {}",
        who, kCheckArgsOption, output);
  }
  if (WIFSIGNALED(wait_status)) {
    return fmt::format("{}: {} killed by signal {}: {}", who, kCheckArgsOption,
                       WTERMSIG(wait_status), output);
  }
  const int code = WIFEXITED(wait_status) ? WEXITSTATUS(wait_status) : 1;
  if (code == 0) return "";
  if (code == 2) return fmt::format("{}: arguments rejected (exit code 2): {}", who, output);
  return fmt::format("{}: {} ended with exit code {} (0 or 2 expected): {}", who, kCheckArgsOption,
                     code, output);
}

}  // namespace

std::vector<std::string> checkExecutables(const LaunchFile& file, const LaunchPlan& plan,
                                          const std::string& bin_dir) {
  std::vector<std::string> problems;
  std::set<std::string> reported;
  const std::vector<std::string> built = builtExecutables(bin_dir);
  for (const LaunchInstance& instance : plan.instances) {
    if (!instance.path.empty() || instance.optional || !reported.insert(instance.name).second) {
      continue;
    }
    std::string where = file.path;
    int line = 0;
    for (const ProcessEntry& e : file.processes) {
      if (e.name == instance.name) {
        where = e.file.empty() ? file.path : e.file;
        line = e.line;
      }
    }
    const std::string meant = config::closestMatch(instance.executable, built);
    problems.push_back(fmt::format(
        "{}:{}: process {}: executable {} not found in {} or PATH{}", where, line, instance.name,
        instance.executable, bin_dir.empty() ? "the launcher's folder" : bin_dir,
        meant.empty() ? std::string(" (add `optional: true` to skip it while it is not built)")
                      : " (did you mean " + meant + "?)"));
  }
  return problems;
}

std::vector<std::string> checkArguments(const std::vector<LaunchInstance>& instances,
                                        const PreflightOptions& options) {
  std::vector<std::string> problems;
  for (const auto& [instance, answer] : askChildren(instances, kCheckArgsOption, options)) {
    if (std::string problem = verdict(*instance, answer); !problem.empty()) {
      problems.push_back(std::move(problem));
    }
  }
  return problems;
}

std::vector<std::pair<const LaunchInstance*, ChildAnswer>> askChildren(
    const std::vector<LaunchInstance>& instances, const char* option,
    const PreflightOptions& options) {
  // Answers in the order of the instances (the children end in any order).
  std::map<const LaunchInstance*, ChildAnswer> found;
  std::vector<const LaunchInstance*> queue;
  for (const LaunchInstance& i : instances) {
    if (!i.path.empty()) queue.push_back(&i);
  }
  std::size_t next = 0;
  std::vector<Check> running;
  while (next < queue.size() || !running.empty()) {
    while (next < queue.size() &&
           static_cast<int>(running.size()) < std::max(1, options.parallel)) {
      Check check = startCheck(*queue[next++], option, options.timeout_s);
      if (check.pid < 0) {
        found[check.instance] = {.wait_status = 0, .failed_to_start = true, .output = check.output};
        continue;
      }
      running.push_back(std::move(check));
    }
    if (running.empty()) continue;
    std::vector<pollfd> fds;
    for (const Check& c : running) {
      if (c.fd >= 0) fds.push_back(pollfd{c.fd, POLLIN, 0});
    }
    // Short waits: a check without output that ends is found by waitpid below.
    ::poll(fds.data(), fds.size(), 20);
    const auto now = PreflightClock::now();
    for (auto it = running.begin(); it != running.end();) {
      readAvailable(*it);
      int status = 0;
      const pid_t done = ::waitpid(it->pid, &status, WNOHANG);
      if (done == 0 && now >= it->deadline && !it->timed_out) {
        it->timed_out = true;
        ::kill(-it->pid, SIGKILL);
      }
      if (done != it->pid) {
        ++it;
        continue;
      }
      readAvailable(*it);
      if (it->fd >= 0) ::close(it->fd);
      found[it->instance] = {
          .wait_status = status, .timed_out = it->timed_out, .output = std::move(it->output)};
      it = running.erase(it);
    }
  }
  std::vector<std::pair<const LaunchInstance*, ChildAnswer>> answers;
  for (const LaunchInstance& i : instances) {
    if (auto it = found.find(&i); it != found.end())
      answers.emplace_back(&i, std::move(it->second));
  }
  return answers;
}

}  // namespace fieldline::launch
