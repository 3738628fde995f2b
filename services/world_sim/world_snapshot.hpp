// The world's state at one instant, enough to continue the simulation from there after the
// simulator process restarts (issue 13 finding 10: a crashed simulator used to restart its
// scenario at t = 0 and every robot jumped back to its start pose). A small text file written
// atomically (temporary file + rename), so a kill -9 in the middle leaves the previous snapshot.
//
//   fieldline-world-snapshot 1
//   scenario default
//   saved_utime 1764612345000000        # node clock when written, us
//   steps 12345                         # physics steps since the scenario's start
//   events 2 0                          # next ball kick, next kidnap
//   ball x y vx vy
//   robot id x y phi vx vy omega c0 c1 c2 s0 s1 s2 a0 a1 a2 kidnaps contact_steps in_contact
//                                  (wheel commands, speeds, angles: c3, s3, a3 too with 4 wheels)
//   rng <the random engine's state>
//   supervisor <text>                   # optional: who started the simulator (see WorldSimNode)
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "services/world_sim/world.hpp"

namespace fieldline::world_sim {

struct WorldSnapshot {
  // Scenario name: a snapshot of another scenario is never resumed.
  std::string scenario;
  // The simulator's clock when the snapshot was taken, us.
  std::int64_t saved_utime = 0;
  std::int64_t steps = 0;
  std::size_t next_kick = 0;
  std::size_t next_kidnap = 0;
  BallTruth ball;
  std::vector<RobotTruth> robots;
  // std::mt19937_64 state as its operator<< writes it.
  std::string rng;
  // The process that started the simulator (its parent's pid and start time), so a restart by
  // the same launcher resumes and a new run does not; empty when unknown.
  std::string supervisor;
};

// Text form; encode(decode(x)) keeps every double bit for bit (17 significant digits).
std::string encodeSnapshot(const WorldSnapshot& snapshot);
// Throws std::runtime_error naming the line for text that is not a snapshot.
WorldSnapshot decodeSnapshot(const std::string& text);

// The snapshot in `path`; nothing when the file does not exist. Throws std::runtime_error for a
// file that cannot be read or parsed.
std::optional<WorldSnapshot> readSnapshotFile(const std::string& path);

}  // namespace fieldline::world_sim
