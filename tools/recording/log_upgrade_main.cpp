// fieldline-log-upgrade: rewrites a recording made with older message types in today's, for tools
// that do not upgrade as they read (lcm-spy, lcm-logplayer, other teams' scripts). The project's
// own readers upgrade on the fly (tools/recording/upgrade.hpp); this writes the same result to a
// file. Events of other channels, and events that need no upgrade, are copied unchanged.
#include <cstdio>
#include <string>

#include <fmt/format.h>

#include "common/bus/cli.hpp"
#include "common/bus/log_file.hpp"
#include "common/cli/cli.hpp"
#include "tools/recording/upgrade.hpp"

using namespace fieldline;

int main(int argc, char** argv) {
  cli::App app{
      "Rewrites an LCM recording whose messages were written with older versions of the "
      "fieldline types (lcmtypes/legacy/) in today's types. Prints what it upgraded; exit code 1 "
      "when nothing could be read. Example: fieldline-log-upgrade old/robot1.lcm new/robot1.lcm"};
  std::string in_path;
  std::string out_path;
  app.add_option("input", in_path, "The old recording")->required()->check(cli::ExistingFile);
  app.add_option("output", out_path, "The upgraded copy (overwritten)")->required();
  FIELDLINE_PARSE(app, argc, argv);
  return bus::runMain("log_upgrade", [&]() -> int {
    if (in_path == out_path) {
      std::fprintf(stderr, "fieldline-log-upgrade: the output must be another file\n");
      return 2;
    }
    recording::installLogUpgrades();
    bus::LogReader in(in_path);
    bus::LogWriter out(out_path);
    bus::LogEvent event;
    while (in.nextEvent(event)) {
      out.write(event.channel, event.timestamp, event.data.data(),
                static_cast<int>(event.data.size()));
    }
    out.flush();
    std::string upgraded;
    for (const auto& [name, n] : in.upgradedByKind())
      upgraded += fmt::format(" {} {}", name, n);
    std::string damaged;
    for (const auto& [kind, n] : in.rejectedByKind())
      damaged += fmt::format(" {} {}", kind, n);
    fmt::print("{}: {} events written; upgraded:{}; damaged:{}\n", out_path, out.eventsWritten(),
               upgraded.empty() ? " none" : upgraded, damaged.empty() ? " none" : damaged);
    return out.eventsWritten() > 0 ? 0 : 1;
  });
}
