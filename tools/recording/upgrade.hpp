// Old recordings keep working after a message type changes (docs/replay.md, "Old recordings").
// The type as it was is kept under lcmtypes/legacy/ (e.g. robot_state_v1_t: lcm's fingerprint
// leaves the struct's name out, so it decodes the old bytes), and one function here turns it into
// today's type. bus::LogReader applies them as it reads (installLogUpgrades() once per process),
// so replay, evaluation, bus-dump and the viewer read an old file as a new one;
// fieldline-log-upgrade rewrites a file for other tools (lcm-spy, lcm-logplayer).
//
// A message change adds: the old .lcm copied to lcmtypes/legacy/NAME_vN_t.lcm (package
// fieldline_legacy, header as fieldline.header_t), an upgrade function below, its line in
// knownUpgrades(), and a recording made before the change to tests/data/recordings/.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "common/bus/log_file.hpp"

namespace fieldline::recording {

struct Upgrade {
  // "robot_state_t v1": the type and the version it upgrades from.
  std::string name;
  // The channel whose events it applies to.
  std::string channel;
  // The fingerprint of the old type's bytes.
  std::int64_t from_fingerprint = 0;
  // Decodes the old bytes and writes the encoded newer message into `out`; false when they do
  // not decode.
  std::function<bool(const void* data, int size, std::vector<std::uint8_t>& out)> convert;
};

// Every upgrade the project knows, oldest first.
const std::vector<Upgrade>& knownUpgrades();

// Rewrites `event`'s data into today's type when it holds an older version of its channel's
// type (several upgrades in a row if need be); the names of the upgrades applied, joined by
// " + ", or nothing.
std::optional<std::string> upgradeEvent(bus::LogEvent& event);

// Makes every bus::LogReader of this process upgrade as it reads.
void installLogUpgrades();

}  // namespace fieldline::recording
