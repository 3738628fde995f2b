// config/team/*.yaml -> the node's options, the UDP options and the key. See
// config/team/sim_team.yaml for every key with its unit and range.
#pragma once

#include <string>

#include "common/config/config.hpp"
#include "teamcomm/teamcomm_node.hpp"
#include "teamcomm/transport.hpp"

namespace fieldline::teamcomm {

struct TeamcommConfig {
  TeamcommOptions node;
  UdpOptions udp;
  // As written in the file; relative paths are taken from the project root.
  std::string key_file;
};

// Reads the `team` section; throws config::Error with file:line: key. The key file is not read.
TeamcommConfig loadTeamcommConfig(const config::Node& root);
// Resolves key_file (relative: from the project root) and reads it; throws KeyError.
TeamKey loadConfiguredKey(const std::string& key_file);

}  // namespace fieldline::teamcomm
