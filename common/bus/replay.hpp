// Log replay through production nodes, deterministic: the nodes under test are the real node
// classes on a memq:// connection, fed the log's events in file order through the real
// subscription path, with a SimulatedClock set to each event's log time before it is delivered.
//
//   SimulatedClock clock;
//   auto memq = bus::Connection::open("memq://");
//   bus::Node vision({.process = "region_tracking", .robot_id = 1}, clock, memq);
//   region_tracking::TrackingNode tracking(vision, options);
//   bus::Node recorder_node({.process = "recorder", .robot_id = 1}, clock, memq);
//   bus::LogWriter out("vision.lcmlog");
//   bus::LogRecorder recorder(recorder_node, out, {bus::channels::kVisionLines.name});
//   bus::Replay replay(clock, memq, {.channels = {std::string(bus::channels::kCameraImage.name)}});
//   replay.add(vision);
//   bus::LogReader log("camera.lcmlog");
//   replay.run(log);
//
// After each event every node is spun until nothing is left to handle, so everything the event
// caused (outputs, outputs of outputs) has happened before the clock moves on. Timers fire when
// the clock passes them, i.e. at the next event's time.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "common/bus/log_file.hpp"
#include "common/bus/node.hpp"
#include "common/time/clock.hpp"
#include "common/time/offset_clock.hpp"

namespace fieldline::bus {

struct ReplayOptions {
  // Channels fed from the log; empty means every channel. A replay that recomputes VISION_*
  // from the images names only CAMERA_IMAGE, so the log's own VISION_* are not fed back.
  std::vector<std::string> channels;
  // The robot's clock against the log's time (tools/recording/clock_model.hpp): the nodes' clock
  // is set to each event's log time as the robot's clock read it, so they run on the clock their
  // messages were stamped with. Zero: the log's time itself.
  ClockError clock;
};

struct ReplayStats {
  // Events published to the nodes.
  std::int64_t delivered = 0;
  // Intact events of channels not replayed.
  std::int64_t skipped = 0;
  // Events stamped earlier than the one before: delivered at the earlier event's time, since the
  // clock never runs backwards.
  std::int64_t out_of_order = 0;
};

class Replay {
 public:
  // `bus` is the connection the nodes under replay are subscribed on (memq://).
  Replay(SimulatedClock& clock, std::shared_ptr<Connection> bus, ReplayOptions options = {});

  // Spins `node` after every event. It must be on `bus` and outlive the replay.
  void add(Node& node);

  // Delivers the next accepted event of a replayed channel (rejected ones are counted by the
  // reader) and lets the nodes handle it. False at the end of the log.
  bool step(LogReader& log);
  // Steps to the end of the log.
  const ReplayStats& run(LogReader& log);
  // Spins every node until none has anything left to handle.
  void settle();

  const ReplayStats& stats() const { return stats_; }

 private:
  bool replayed(std::string_view channel) const;

  SimulatedClock& clock_;
  ReplayOptions options_;
  Node publisher_;
  std::vector<Node*> nodes_;
  LogEvent event_;
  ReplayStats stats_;
  bool started_ = false;
};

// Records what `node` receives on the named channels into a log, stamped with the node's clock
// (so a replay's recording is the same file every time), or with that time converted back to the
// recorded log's clock (setLogClock), so the output lines up with the recording it came from.
class LogRecorder {
 public:
  LogRecorder(Node& node, LogWriter& writer, std::vector<std::string_view> channels,
              BusId bus = kPrimaryBus);

  std::int64_t recorded() const { return recorded_; }
  // The node's clock is this robot clock of the log's time: events are written at log time.
  void setLogClock(const ClockError& clock) { log_clock_ = clock; }

 private:
  Node& node_;
  ClockError log_clock_;
  LogWriter& writer_;
  std::vector<std::string> channels_;
  std::int64_t recorded_ = 0;
};

}  // namespace fieldline::bus
