// fieldline-teamcomm: the team link of one robot. Sends its ROBOT_STATE and BALL_STATE to the
// teammates in authenticated UDP packets, receives theirs, estimates their clock offsets and
// publishes the team picture as TEAM_STATE.
#include <fmt/format.h>
#include <net/if.h>
#include <spdlog/spdlog.h>

#include <iostream>
#include <memory>

#include "common/bus/cli.hpp"
#include "common/bus/node.hpp"
#include "common/bus/robot_clock.hpp"
#include "common/cli/cli.hpp"
#include "common/config/config.hpp"
#include "teamcomm/team_key.hpp"
#include "teamcomm/teamcomm_config.hpp"
#include "teamcomm/teamcomm_node.hpp"
#include "teamcomm/transport.hpp"

using namespace fieldline;

// long: the command line of the team link (options, checks, --print-io, --check-args) in order.
int main(int argc, char** argv) {
  cli::App app{
      "Team communication: own pose and ball to the teammates over authenticated UDP "
      "(multicast or unicast peers), theirs back with clock offsets from the packets' round "
      "trips, and the team picture with a fused team ball as TEAM_STATE at 10 Hz. Protocol: "
      "docs/team-protocol.md. Clock error of a simulated robot: FIELDLINE_CLOCK_OFFSET_US, "
      "FIELDLINE_CLOCK_DRIFT_PPM, FIELDLINE_CLOCK_REFERENCE_US."};
  bus::CommonOptions common;
  common.addTo(app);
  std::string team_config = "sim_team";
  app.add_option("--team-config", team_config,
                 "Team preset in config/team/ or a YAML path (team id, key file, transport)")
      ->capture_default_str();
  std::string key_file;
  app.add_option("--key-file", key_file,
                 "The team key file, instead of the team config's key_file (systemd hands the "
                 "robot's key over as a credential: --key-file %d/team.key)");
  int port = 0;
  app.add_option("--port", port, "Override the UDP port of the team config")
      ->check(cli::Range(1, 65535));
  try {
    app.parse(argc, argv);
  } catch (const cli::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }

  return bus::runMain("teamcomm", [&] {
    common.resolve("teamcomm");
    teamcomm::TeamcommConfig cfg = teamcomm::loadTeamcommConfig(
        config::Node::loadFile(config::resolvePreset("team", team_config)));
    cfg.node.expect_own_echo = !cfg.udp.group.empty() && cfg.udp.loopback;
    if (port != 0) cfg.udp.port = static_cast<std::uint16_t>(port);
    // The robot's own LCM bus on the team port: the team link would hear the bus's traffic.
    if (const auto bus_port = teamcomm::udpmPort(common.bus_url);
        bus_port && *bus_port == cfg.udp.port) {
      throw config::Error("the team port " + std::to_string(cfg.udp.port) +
                          " is this robot's bus port too (" + common.bus_url +
                          "): change the team config's transport.port or the bus's port");
    }
    for (const std::string& w : cfg.warnings)
      spdlog::warn("{}", w);
    if (common.robot < 1 || common.robot > teamcomm::kMaxRobots) {
      throw config::Error("--robot must be 1..6 for teamcomm");
    }
    try {
      cfg.node.key = key_file.empty() ? teamcomm::loadConfiguredKey(cfg.key_file)
                                      : teamcomm::loadTeamKey(key_file);
    } catch (const teamcomm::KeyError& e) {
      throw config::Error(std::string("team key: ") + e.what());
    }
    const RobotClock clock = bus::robotClockFromEnvironment();

    if (common.print_io) {
      const std::string network =
          cfg.udp.group.empty()
              ? fmt::format("unicast port {} to {} peers", cfg.udp.port, cfg.udp.peers.size())
              : fmt::format("{}:{}", cfg.udp.group, cfg.udp.port);
      return bus::printIo(teamcomm::teamcommIo().link("udp", network, bus::Link::Direction::kBoth));
    }
    if (common.check_args) {
      // The network interface is this process's device.
      if (!cfg.udp.interface.empty() && ::if_nametoindex(cfg.udp.interface.c_str()) == 0) {
        std::cerr << "teamcomm: " << cfg.udp.interface
                  << ": no such network interface; list them with ip link (transport.interface "
                     "in the team config)\n";
        return 2;
      }
      return 0;
    }
    std::unique_ptr<teamcomm::PacketLink> link;
    try {
      link = teamcomm::openUdpLink(cfg.udp);
    } catch (const teamcomm::TransportError& e) {
      // The network is this process's device: without it, it cannot do its job.
      throw bus::BusError(e.what());
    }
    bus::installStopSignals();
    bus::Node node({.process = "teamcomm", .robot_id = common.robot, .url = common.bus_url}, clock);
    teamcomm::TeamcommNode team(node, *link, cfg.node);
    spdlog::info(
        "team {} robot {}: {} {}:{} at {} Hz", cfg.node.team_id, common.robot,
        cfg.udp.group.empty() ? "unicast" : "multicast",
        cfg.udp.group.empty() ? std::to_string(cfg.udp.peers.size()) + " peers" : cfg.udp.group,
        cfg.udp.port, cfg.node.send_rate_hz);
    return node.run();
  });
}
