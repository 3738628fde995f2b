// The robots' serial lines as the simulator drives them, on simulated time and without a bus: a
// firmware emulator per robot behind a pseudo-terminal (<pty_dir>/robot<N>.tty), the scenario's
// outages (the pty closes, as when a USB cable is pulled, and a new one opens after the
// outage), and the controller's latency queue (an odometry frame leaves controller_latency after
// its sampling).
//
// Per physics step: beforeStep() (outages, reopening, bytes both ways, motor commands into the
// world), World::step(), afterStep() (odometry samples due at the new time).
#pragma once

#include <cstdint>
#include <deque>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "common/scenario/scenario.hpp"
#include "services/world_sim/firmware.hpp"
#include "services/world_sim/pseudo_terminal.hpp"
#include "services/world_sim/world.hpp"

namespace fieldline::world_sim {

// The path of robot `robot_id`'s serial link in `pty_dir`: <pty_dir>/robot<N>.tty.
std::string serialLinkPath(const std::string& pty_dir, int robot_id);

class SerialLines {
 public:
  // Seconds before a pty that could not be reopened is tried again.
  static constexpr double kReopenRetry = 1.0;

  // Opens a line per robot of `world`; throws std::runtime_error when a pty cannot be opened.
  SerialLines(const World& world, std::string pty_dir);

  // The world continues at simulated time `t` (a resumed snapshot): odometry samples from `t`
  // on, outages scheduled before `t` are skipped.
  void resumeAt(double t);

  void beforeStep(World& world);
  void afterStep(const World& world);
  // Pulls robot `index`'s line at simulated time `t` for `duration` seconds (no-op while pulled).
  void pull(std::size_t index, double t, double duration);
  void pullAll(double t, double duration);

  std::size_t size() const { return lines_.size(); }
  bool isOpen(std::size_t index) const { return lines_.at(index).pty != nullptr; }
  const std::string& linkPath(std::size_t index) const { return lines_.at(index).link_path; }
  const FirmwareEmulator& firmware(std::size_t index) const { return *lines_.at(index).firmware; }
  // Bytes the robot's side wrote that nobody read (the bridge is away or slow).
  std::uint64_t bytesDropped(std::size_t index) const { return lines_.at(index).bytes_dropped; }
  // Why reopening failed since the last call (the simulation goes on without that line).
  std::vector<std::string> takeErrors() { return std::exchange(errors_, {}); }

 private:
  struct Line {
    int robot_id = 0;
    std::unique_ptr<FirmwareEmulator> firmware;
    std::unique_ptr<PseudoTerminal> pty;
    std::string link_path;
    double next_sample = 0.0;
    // While the line is pulled: reopen at this simulated time; negative while open.
    double reopen_at = -1.0;
    std::uint64_t bytes_dropped = 0;
    // Odometry frames on their way, with the simulated time they leave the controller.
    std::deque<std::pair<double, std::vector<std::uint8_t>>> outgoing;
  };

  void reopenIfDue(Line& line, double t);
  void exchangeBytes(Line& line, double t);

  double sample_period_;
  double controller_latency_;
  std::vector<Line> lines_;
  std::vector<scenario::SerialOutageSpec> outages_;  // by time
  std::size_t next_outage_ = 0;
  std::vector<std::uint8_t> in_;
  std::vector<std::uint8_t> out_;
  std::vector<std::string> errors_;
};

}  // namespace fieldline::world_sim
