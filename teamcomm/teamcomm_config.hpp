// config/team/*.yaml -> the node's options, the UDP options and the key. See
// config/team/sim_team.yaml for every key with its unit and range.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common/config/config.hpp"
#include "teamcomm/teamcomm_node.hpp"
#include "teamcomm/transport.hpp"

namespace fieldline::teamcomm {

struct TeamcommConfig {
  TeamcommOptions node;
  UdpOptions udp;
  // As written in the file; relative paths are taken from the project root.
  std::string key_file;
  // Settings that work but are probably not meant (file:line: what and why), for the log.
  std::vector<std::string> warnings;
};

// A team multicast group: "" when usable, else why not (not a dotted IPv4 address, not a
// multicast group, or in 224.0.0.0/24, the local network control block: 224.0.0.1 reaches every
// host). A usable group outside 239.0.0.0/8 (administratively scoped) adds a warning.
std::string checkTeamGroup(const std::string& group, std::vector<std::string>* warnings = nullptr);

// The port of an LCM udpm URL ("udpm://239.255.76.67:7668?ttl=0"), nothing for other URLs.
std::optional<std::uint16_t> udpmPort(const std::string& url);

// Reads the `team` section; throws config::Error with file:line: key. The key file is not read.
TeamcommConfig loadTeamcommConfig(const config::Node& root);
// Resolves key_file (relative: from the project root) and reads it; throws KeyError.
TeamKey loadConfiguredKey(const std::string& key_file);

}  // namespace fieldline::teamcomm
