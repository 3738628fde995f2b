// What the launcher checks before it starts anything (and all that --dry-run does): every
// executable of the plan exists (a name that is not found is an error naming the closest built
// fieldline executable, unless its entry says `optional: true`), and every child accepts its
// command line: it is run once with `--check-args` appended, which every fieldline executable
// answers by parsing its arguments and configuration and exiting 0 (valid) or 2 (not), starting
// nothing. The launch file's own values (multicast group, ports) are checked when it is read.
#pragma once

#include <string>
#include <vector>

#include "tools/launch/plan.hpp"

namespace fieldline::launch {

// The option every fieldline executable understands (common/bus/cli.hpp).
inline constexpr const char* kCheckArgsOption = "--check-args";

struct PreflightOptions {
  // A check that has not ended after this long is killed and counted as a problem, s.
  double timeout_s = 20.0;
  // Checks running at the same time.
  int parallel = 4;
};

// One problem per entry whose executable is missing and not optional: "team.yaml:12: process
// camera: executable fieldline-camrea not found in BIN or PATH (did you mean fieldline-camera?)".
std::vector<std::string> checkExecutables(const LaunchFile& file, const LaunchPlan& plan,
                                          const std::string& bin_dir);

// Runs every built instance's command line with --check-args appended (its environment
// entries added) and returns one problem per instance that did not exit 0, with the last lines
// of its output: "r1 camera: arguments rejected (exit code 2): ...".
std::vector<std::string> checkArguments(const std::vector<LaunchInstance>& instances,
                                        const PreflightOptions& options = {});

// How a child run with one option appended ended.
struct ChildAnswer {
  // As waitpid() reports it.
  int wait_status = 0;
  // It could not be started (fork or pipe failed): `output` says why.
  bool failed_to_start = false;
  // Killed at PreflightOptions::timeout_s.
  bool timed_out = false;
  // Its stdout and stderr (the last 16 kB).
  std::string output;
};

// Runs every built instance's command line with `option` appended (--check-args, --print-io),
// `options.parallel` at a time; the answers in the order of the instances.
std::vector<std::pair<const LaunchInstance*, ChildAnswer>> askChildren(
    const std::vector<LaunchInstance>& instances, const char* option,
    const PreflightOptions& options = {});

}  // namespace fieldline::launch
