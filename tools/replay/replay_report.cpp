// What a replay reports: totals, the refusals, the failures against the options, the summary.
#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "common/bus/channels.hpp"
#include "tools/replay/replay_run.hpp"

namespace fieldline::replay {

namespace ch = bus::channels;

std::int64_t ReplayRunResult::fedTotal() const {
  std::int64_t n = 0;
  for (const auto& [channel, count] : in)
    n += count;
  return n;
}

std::int64_t ReplayRunResult::refusedTotal() const {
  std::int64_t n = 0;
  for (const auto& [kind, count] : rejected)
    n += count;
  for (const auto& [kind, count] : node_errors)
    n += count;
  return n;
}

namespace {

double refusedShare(const ReplayRunResult& result) {
  // Events the reader refused never reached the nodes: they count among the inputs.
  std::int64_t reader = 0;
  for (const auto& [kind, count] : result.rejected)
    reader += count;
  const std::int64_t offered = result.fedTotal() + reader;
  return offered > 0 ? static_cast<double>(result.refusedTotal()) / static_cast<double>(offered)
                     : 0.0;
}

}  // namespace

std::string refusalReport(const ReplayRunResult& result) {
  const std::int64_t refused = result.refusedTotal();
  if (refused == 0) return {};
  std::int64_t reader = 0;
  for (const auto& [kind, count] : result.rejected)
    reader += count;
  std::string text = fmt::format("refused {} of {} inputs ({:.2f} %):", refused,
                                 result.fedTotal() + reader, 100.0 * refusedShare(result));
  const auto line = [&](const std::string& kind, std::int64_t count) {
    text += fmt::format("\n  {} {}", kind, count);
    const auto it = result.refusal_examples.find(kind);
    if (it != result.refusal_examples.end() && !it->second.empty()) text += ": " + it->second;
  };
  for (const auto& [kind, count] : result.rejected)
    line("reader/" + kind, count);
  for (const auto& [kind, count] : result.node_errors)
    line(kind, count);
  for (const auto& [kind, example] : result.refusal_examples) {
    if (kind.size() > 5 && kind.compare(kind.size() - 5, 5, "/last") == 0)
      text += fmt::format("\n  {} error: {}", kind.substr(0, kind.size() - 5), example);
  }
  return text;
}

std::vector<std::string> failures(const ReplayRunResult& result, const ReplayRunOptions& options) {
  std::vector<std::string> why;
  const double share = refusedShare(result);
  std::int64_t outputs = 0;
  for (const auto& [channel, count] : result.out)
    outputs += count;
  if (result.fedTotal() == 0) {
    why.push_back("no input reached the nodes (nothing in the log on the channels they read)");
  }
  if (share > options.max_refused_share) {
    why.push_back(
        fmt::format("{:.1f} % of the inputs were refused (at most {:.1f} % allowed; "
                    "see the kinds above)",
                    100.0 * share, 100.0 * options.max_refused_share));
  }
  if (std::find(options.run.begin(), options.run.end(), "fusion") != options.run.end()) {
    if (result.tracking_states == 0) {
      const auto it = result.out.find(std::string(ch::kRobotState.name));
      why.push_back(
          fmt::format("fusion published no valid estimate ({} ROBOT_STATE, none of "
                      "them tracking)",
                      it == result.out.end() ? 0 : it->second));
    }
  } else if (outputs == 0) {
    why.push_back("the nodes published nothing");
  }
  return why;
}

std::string summaryLine(const ReplayRunResult& result) {
  std::ostringstream line;
  line << "replay robot " << result.robot_id;
  if (result.parts > 1) line << " (" << result.parts << " files)";
  line << ": in";
  for (const auto& [channel, n] : result.in)
    line << ' ' << channel << ' ' << n;
  line << " | out";
  for (const auto& [channel, n] : result.out)
    line << ' ' << channel << ' ' << n;
  line << " | skipped " << result.skipped;
  std::int64_t rejected = 0;
  for (const auto& [kind, n] : result.rejected)
    rejected += n;
  line << " rejected " << rejected;
  std::int64_t refused = 0;
  for (const auto& [kind, n] : result.node_errors)
    refused += n;
  line << " refused " << refused << " out_of_order " << result.out_of_order;
  if (result.truth_merged > 0) line << " | SIM_WORLD merged " << result.truth_merged;
  if (result.live_written > 0) line << " | live events " << result.live_written;
  if (result.oracle_contacts > 0) line << " | oracle contacts " << result.oracle_contacts;
  if (result.stalls > 0) {
    line << " | stalls " << result.stalls << " held " << result.stall_held << " dropped "
         << result.stall_dropped;
  }
  if (result.out.count(std::string(ch::kRobotState.name)) > 0)
    line << " | tracking " << result.tracking_states;
  if (!result.upgraded.empty()) {
    line << " | upgraded";
    for (const auto& [name, n] : result.upgraded)
      line << ' ' << name << ' ' << n;
  }
  line << " | clock " << result.clock.describe() << " | field " << result.field;
  if (!result.fusion_config.empty()) line << ", fusion settings " << result.fusion_config;
  return line.str();
}
}  // namespace fieldline::replay
