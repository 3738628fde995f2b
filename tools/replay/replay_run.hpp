// fieldline-replay's core: a recorded robot-bus log fed through the production nodes of the
// named algorithms (feature_recognition, fusion, region_tracking) in one process, on memq://
// under a simulated clock, in log-time order, with fixed publisher ids; what they publish is
// written to an LCM log. The same log and options give the same output bytes.
//
// The log's own messages on channels a run node produces (e.g. the live FIELD_FEATURES when
// feature_recognition runs) are not fed: the replayed outputs replace them.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <fieldline/world_state_t.hpp>

#include "common/time/clock.hpp"
#include "tools/recording/clock_model.hpp"

namespace fieldline::replay {

// A node name that is not one of kRunnableNodes, or options that cannot work.
class ReplayArgumentError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

// What --run accepts, in the order the nodes are created.
inline const std::vector<std::string> kRunnableNodes{"region_tracking", "feature_recognition",
                                                     "fusion"};

struct ReplayRunOptions {
  // One robot's log, or a recording's directory (then robot_id says whose files; its sim.lcm is
  // the truth unless truth_path is given).
  std::string log_path;
  // Written (truncated) with the run nodes' outputs; empty: nothing is written.
  std::string out_path;
  std::vector<std::string> run;
  // 1..6; 0: the robot id of the first ODOMETRY / VISION_LINES / CAMERA_IMAGE in the log.
  int robot_id = 0;
  // As the processes take them (their --help). Empty field and fusion_config: the recording's own
  // (RECORDING_INFO's field and fusion settings), else msl and default.
  std::string field;
  std::string robot_config = "fu2004";
  std::string camera = "omni_sim";
  // fusion: settings preset (config/fusion/NAME.yaml) or path, as fieldline-fusion --config;
  // matcher (when not empty) and start_prior override it.
  std::string fusion_config;
  std::string matcher;
  std::string start_prior = "own_half";
  // Distance grid cache of the line matcher; empty: built in memory.
  std::string grid_cache;
  // The simulator's log of the same run (scripts/demo --record's sim.lcm): its SIM_WORLD is
  // merged into out_path and live_out_path in log-time order, so that fieldline-eval --log can
  // score each file on its own. Empty: none.
  std::string truth_path;
  // Written with what the live processes published on the channels the run nodes produce (the
  // log's own ROBOT_STATE, FIELD_FEATURES, ...) and the truth: the live run to compare the
  // replay with. Empty: not written.
  std::string live_out_path;
  // Analysis only, never in a process (fieldline-replay --oracle-contact): the log's
  // VISION_OBSTACLES are replaced by the truth's contact state, to measure what a perfect contact
  // signal could give. At every SIM_WORLD sample of truth_path in which this robot's centre is
  // closer to another robot's or an opponent's than the two radii, fusion receives a
  // VISION_OBSTACLES frame stamped with that sample's time holding one obstacle at the body
  // (distance 0): the path real contact evidence takes. Needs truth_path.
  bool oracle_contact = false;
  // Analysis: stalls injected as a starved process sees them. Every `stall_every_s` seconds of
  // log time, starting `stall_start_s` after the first fed event, for `stall_s` seconds the
  // events of `stall_hold` channels are held and delivered together at the stall's end (arrival
  // time = the end, order kept: the queued datagrams reach a process that got no CPU, or a
  // starved motor bridge reads the serial line's backlog), those of `stall_drop` channels are
  // dropped (a starved camera renders no frames), the others pass unchanged. A channel not fed
  // is ignored. stall_s 0: off.
  double stall_every_s = 10.0;
  double stall_start_s = 5.0;
  double stall_s = 0.0;
  std::vector<std::string> stall_hold;
  std::vector<std::string> stall_drop;
  // The robot's clock against the log's time. Unset: the recording's own (RECORDING_INFO), else
  // fitted to the log's traffic (recording/clock_model.hpp). The nodes run on the robot's clock,
  // the outputs are written at the log's time.
  std::optional<ClockError> clock;
  // The replay fails (exit code 1) when more than this share of the fed inputs was refused.
  double max_refused_share = 0.02;
};

struct ReplayRunResult {
  int robot_id = 0;
  // Messages fed from the log, by channel.
  std::map<std::string, std::int64_t> in;
  // Messages the run nodes published (and the output log holds), by channel.
  std::map<std::string, std::int64_t> out;
  // Log events of channels not fed (the replaced outputs, channels no run node reads).
  std::int64_t skipped = 0;
  std::int64_t out_of_order = 0;
  // Log events of older message versions upgraded while reading, by upgrade (upgrade.hpp).
  std::map<std::string, std::int64_t> upgraded;
  // Log events refused by the reader's checks, by kind (log_file.hpp).
  std::map<std::string, std::int64_t> rejected;
  // Errors the run nodes reported (refused inputs), by "node/kind".
  std::map<std::string, std::int64_t> node_errors;
  // SIM_WORLD messages merged from the truth log (into each output).
  std::int64_t truth_merged = 0;
  // Events written to live_out_path.
  std::int64_t live_written = 0;
  // oracle_contact: SIM_WORLD samples of this robot in contact (each one fed as evidence).
  std::int64_t oracle_contacts = 0;
  // stall_s: stalls injected, inputs held by them, inputs dropped by them.
  std::int64_t stalls = 0;
  std::int64_t stall_held = 0;
  std::int64_t stall_dropped = 0;
  // Files of the recording replayed as one log (a recording split by size).
  int parts = 1;
  // The robot's clock the replay ran on, and how it was found.
  recording::RobotClockModel clock;
  // The field and fusion settings the replay ran with, and where they came from ("msl (the
  // recording's)").
  std::string field;
  std::string fusion_config;
  // The last reason given: per kind of the reader ("reader/future_utime"), per node the node's
  // last error ("fusion/last").
  std::map<std::string, std::string> refusal_examples;
  // ROBOT_STATE published with STATUS_TRACKING: the valid estimates.
  std::int64_t tracking_states = 0;
  // Events fed to the nodes (the sum of `in`), and those refused by the reader's checks or the
  // nodes (the sum of `rejected` and `node_errors`).
  std::int64_t fedTotal() const;
  std::int64_t refusedTotal() const;
};

// The stall times of ReplayRunOptions. `first` is the log's first fed event time.
struct StallSchedule {
  Utime first = 0;
  double every_s = 10.0;
  double start_s = 5.0;
  double length_s = 0.0;
  // The stall an event received at `t` falls into (0, 1, ...), or -1.
  std::int64_t stallAt(Utime t) const;
  // The end of stall `k`, log time.
  Utime stallEnd(std::int64_t k) const;
};

// oracle_contact's test: true when robot `robot_id` of `world` touches another robot or an
// opponent (centres closer than the two radii plus 1 cm: the simulator leaves touching bodies
// at exactly the two radii). False when the robot is not in `world`.
bool touchesAnotherRobot(const world_state_t& world, int robot_id);

// The channels each runnable node reads and writes.
std::vector<std::string> inputChannels(const std::string& node);
std::vector<std::string> outputChannels(const std::string& node);

// Parses "feature_recognition,fusion"; throws ReplayArgumentError for unknown or repeated names.
std::vector<std::string> parseRunList(const std::string& text);

// Throws ReplayArgumentError for bad options, bus::LogError for unreadable logs, config errors
// for bad presets.
ReplayRunResult runReplay(const ReplayRunOptions& options);

// A source of mergeLogs: a log and the channels taken from it (empty: every channel).
struct MergeSource {
  std::string path;
  std::vector<std::string> channels;
};

// Writes the checked events of `sources` on their channels into `out_path`, in log-time order
// (ties: the earlier source first). Returns the events written.
std::int64_t mergeLogs(const std::vector<MergeSource>& sources, const std::string& out_path);

// One line: "replay robot 1: in ODOMETRY 1500 VISION_LINES 300 ... | out ROBOT_STATE 1500 ...".
std::string summaryLine(const ReplayRunResult& result);

// What the replay refused and why, one line per kind ("refused 3017 of 3120 inputs (96.7 %):"
// then "  reader/future_utime 3017: VISION_LINES: utime ... is 512 ms in the future"); empty
// when nothing was refused.
std::string refusalReport(const ReplayRunResult& result);

// Why the replay failed, one sentence per reason: more than `max_refused_share` of the fed
// inputs refused, nothing fed, fusion run but no ROBOT_STATE tracking, no output at all. Empty:
// the replay did its job.
std::vector<std::string> failures(const ReplayRunResult& result, const ReplayRunOptions& options);

}  // namespace fieldline::replay
