// The world_sim process's bus side: steps the world in real time (up to the node's clock, never
// ahead of it), drives the serial lines (serial_lines.hpp) and publishes SIM_WORLD ground truth
// on the node's primary bus (the simulator's), stamped with the simulated physical time.
#pragma once

#include <optional>
#include <string>

#include <fieldline/world_state_t.hpp>

#include "common/bus/node.hpp"
#include "common/perception/world_truth.hpp"
#include "common/process/state_file.hpp"
#include "common/scenario/scenario.hpp"
#include "services/world_sim/published_motion.hpp"
#include "services/world_sim/serial_lines.hpp"
#include "services/world_sim/world.hpp"

namespace fieldline::world_sim {

struct WorldSimNodeOptions {
  // Folder of the robots' serial links robot<N>.tty.
  std::string pty_dir = "/tmp/fieldline";
  // SIM_WORLD messages per simulated second.
  double world_rate = 100.0;
  // Snapshot of the world written every snapshot_period_s (world_snapshot.hpp) and at every stop
  // (a crash, SIGTERM, systemctl restart); a restart continues from it. Empty: none.
  std::string state_file;
  double snapshot_period_s = 0.1;
  // A snapshot older than this (by the node's clock) is not resumed: the scenario starts over.
  double resume_within_s = 5.0;
  // Start the scenario from t = 0 whatever the state file holds.
  bool fresh = false;
  // Who started this simulator (process::supervisorIdentity()): a snapshot written under another
  // supervisor (a new run of the launcher, another team sharing the folder) is not resumed.
  // Empty: not checked.
  std::string supervisor;
};

// What the simulator reads and writes: SIM_WORLD and a serial line per robot of `scenario`
// (fieldline-world-sim --print-io).
bus::ProcessIo worldSimIo(const scenario::Scenario& scenario, const std::string& pty_dir);

class WorldSimNode {
 public:
  // Simulated time 0 is the node's clock now, or, when options.state_file holds a recent
  // snapshot of this scenario, the world continues from it (its simulated time goes on from
  // the snapshot's, the node's clock now). Opens the serial lines; sets a timer at the physics
  // rate. Throws std::runtime_error when a pty cannot be opened, std::invalid_argument for a
  // world rate that is not positive.
  WorldSimNode(bus::Node& node, const scenario::Scenario& scenario, WorldSimNodeOptions options);
  // Writes a last snapshot: a restart that is not asked to be fresh continues from here (a clean
  // stop used to remove it, and the restart began the scenario again at t = 0).
  ~WorldSimNode();
  WorldSimNode(const WorldSimNode&) = delete;
  WorldSimNode& operator=(const WorldSimNode&) = delete;

  // Whether the world was resumed from a snapshot, and at which simulated time.
  bool resumed() const { return resumed_; }
  // Writes the state file now (also done by a timer).
  void writeSnapshot();

  // Steps the world up to the node's clock. At the scenario's end its script (kicks, kidnaps)
  // is over and the world goes on as it is until the process is stopped: ending the process
  // there had its supervisor restart the scenario at t = 0, every robot jumping back.
  void update();
  // Pulls every serial line for `duration` seconds (SIGUSR1 in the process).
  void pullSerialLines(double duration);
  // The scenario's duration is over (its script ended; the world still runs).
  bool finished() const;

  const World& world() const { return world_; }
  const SerialLines& lines() const { return lines_; }
  // The node's clock at simulated time `t` [s].
  Utime utimeAt(double t) const;

 private:
  void publishWorld();
  void publishMetrics();
  void resumeFromStateFile();

  bus::Node& node_;
  WorldSimNodeOptions options_;
  World world_;
  SerialLines lines_;
  Utime start_;
  double next_world_ = 0.0;
  bool resumed_ = false;
  bool end_logged_ = false;
  perception::WorldTruth truth_;
  // The robots' velocities SIM_WORLD carries: the mean since the previous SIM_WORLD.
  PublishedMotionTracker published_motion_;
  world_state_t msg_{};
  // The snapshot file (options_.state_file), written over in place 10 times a second.
  std::optional<process::StateFileWriter> snapshot_file_;
};

}  // namespace fieldline::world_sim
