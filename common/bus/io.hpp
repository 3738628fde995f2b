// What a process reads and writes, declared in one place per service: the channels of the table
// in channels.hpp it subscribes to and publishes, and what it exchanges outside LCM (a camera, a
// serial line, the team network). The node checks its own use against the declaration
// (Node::declareIo: a subscription or a publication that is not declared is refused, a declared
// input nobody subscribes to is an error), and every service prints it without starting
// (`--print-io`), which is how `fieldline-launch --graph` draws a launch file's data flow.
//
//   bus::ProcessIo fusionIo() {
//     return bus::ProcessIo("fusion")
//         .reads(bus::channels::kOdometry)
//         .readsIfPresent(bus::channels::kTeamState)
//         .writes(bus::channels::kRobotState);
//   }
//
// SERVICE_STATUS is not declared: every node publishes it on its primary bus.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "common/bus/channels.hpp"

namespace fieldline::bus {

enum class BusKind {
  // The bus of the process's own robot (of every robot, for a monitor).
  kRobot,
  // The simulator's bus.
  kSim,
};

// The bus a channel travels on: SIM_WORLD on the simulator's, every other on a robot's.
BusKind homeBus(std::string_view channel);
const char* toString(BusKind bus);

struct ChannelUse {
  std::string channel;
  // false: the process uses it when it is there and does its job without it.
  bool required = true;
  // A monitor's input, read on the bus of every robot of the launch, not only its own robot's.
  bool every_robot = false;
};

// Something outside LCM that data flows through.
struct Link {
  enum class Direction { kIn, kOut, kBoth };
  // "camera" (a V4L2 device, a video, a pipeline), "serial" (a motor controller or its
  // emulator's pseudo-terminal), "file", "pipe", "udp" (the team network), "http".
  std::string kind;
  // A path, an address or a pipeline.
  std::string name;
  Direction direction = Direction::kIn;
};
const char* toString(Link::Direction direction);

class ProcessIo {
 public:
  explicit ProcessIo(std::string process = {});

  template <typename Msg>
  ProcessIo& reads(Channel<Msg> channel) {
    return addInput({std::string(channel.name), true, false});
  }
  template <typename Msg>
  ProcessIo& readsIfPresent(Channel<Msg> channel) {
    return addInput({std::string(channel.name), false, false});
  }
  // A monitor's optional input on every robot's bus.
  template <typename Msg>
  ProcessIo& readsFromEveryRobot(Channel<Msg> channel) {
    return addInput({std::string(channel.name), false, true});
  }
  template <typename Msg>
  ProcessIo& writes(Channel<Msg> channel) {
    return addOutput({std::string(channel.name), true, false});
  }
  ProcessIo& link(std::string kind, std::string name, Link::Direction direction);

  ProcessIo& addInput(ChannelUse use);
  ProcessIo& addOutput(ChannelUse use);

  const std::string& process() const { return process_; }
  const std::vector<ChannelUse>& inputs() const { return inputs_; }
  const std::vector<ChannelUse>& outputs() const { return outputs_; }
  const std::vector<Link>& links() const { return links_; }
  bool readsChannel(std::string_view channel) const;
  // SERVICE_STATUS counts as written by every process.
  bool writesChannel(std::string_view channel) const;

  // The declaration as YAML (what --print-io prints; parseProcessIo reads it back).
  std::string toYaml() const;

 private:
  std::string process_;
  std::vector<ChannelUse> inputs_;
  std::vector<ChannelUse> outputs_;
  std::vector<Link> links_;
};

// The line --print-io prints before the YAML (a YAML document start): log lines may precede it.
inline constexpr const char* kIoMarker = "--- # fieldline --print-io";

// Reads what printIo printed (the YAML after the last kIoMarker, or all of `text` without one);
// throws config::Error naming `origin` and the key on anything else (an unknown channel too).
ProcessIo parseProcessIo(const std::string& text, const std::string& origin);

// Prints kIoMarker and the declaration for --print-io; returns main()'s exit code (0).
int printIo(const ProcessIo& io);

}  // namespace fieldline::bus
