#include "common/bus/io.hpp"

#include <algorithm>
#include <cstdio>
#include <stdexcept>

#include <yaml-cpp/yaml.h>

#include "common/config/config.hpp"

namespace fieldline::bus {

namespace {

bool knownChannel(std::string_view channel) {
  return std::find(kAllChannelNames.begin(), kAllChannelNames.end(), channel) !=
         kAllChannelNames.end();
}

bool contains(const std::vector<ChannelUse>& uses, std::string_view channel) {
  return std::any_of(uses.begin(), uses.end(),
                     [&](const ChannelUse& u) { return u.channel == channel; });
}

// A declaration of a channel twice (or of one that is no channel) is a programming error.
void add(std::vector<ChannelUse>& uses, ChannelUse use, const std::string& process) {
  if (!knownChannel(use.channel)) {
    throw std::logic_error(process + " declares '" + use.channel + "', which is no channel");
  }
  if (contains(uses, use.channel)) {
    throw std::logic_error(process + " declares " + use.channel + " twice");
  }
  uses.push_back(std::move(use));
}

Link::Direction directionOf(const std::string& text) {
  if (text == "in") return Link::Direction::kIn;
  if (text == "out") return Link::Direction::kOut;
  return Link::Direction::kBoth;
}

}  // namespace

BusKind homeBus(std::string_view channel) {
  return channel == channels::kSimWorld.name ? BusKind::kSim : BusKind::kRobot;
}

const char* toString(BusKind bus) {
  return bus == BusKind::kSim ? "sim" : "robot";
}

const char* toString(Link::Direction direction) {
  switch (direction) {
    case Link::Direction::kIn:
      return "in";
    case Link::Direction::kOut:
      return "out";
    case Link::Direction::kBoth:
      return "both";
  }
  return "both";
}

ProcessIo::ProcessIo(std::string process) : process_(std::move(process)) {}

ProcessIo& ProcessIo::addInput(ChannelUse use) {
  add(inputs_, std::move(use), process_);
  return *this;
}

ProcessIo& ProcessIo::addOutput(ChannelUse use) {
  add(outputs_, std::move(use), process_);
  return *this;
}

ProcessIo& ProcessIo::link(std::string kind, std::string name, Link::Direction direction) {
  links_.push_back({std::move(kind), std::move(name), direction});
  return *this;
}

bool ProcessIo::readsChannel(std::string_view channel) const {
  return contains(inputs_, channel);
}

bool ProcessIo::writesChannel(std::string_view channel) const {
  return channel == channels::kServiceStatus.name || contains(outputs_, channel);
}

std::string ProcessIo::toYaml() const {
  YAML::Emitter out;
  out << YAML::BeginMap << YAML::Key << "process" << YAML::Value << process_;
  out << YAML::Key << "reads" << YAML::Value << YAML::BeginSeq;
  for (const ChannelUse& u : inputs_) {
    out << YAML::Flow << YAML::BeginMap << YAML::Key << "channel" << YAML::Value << u.channel
        << YAML::Key << "bus" << YAML::Value << toString(homeBus(u.channel)) << YAML::Key
        << "required" << YAML::Value << u.required << YAML::Key << "every_robot" << YAML::Value
        << u.every_robot << YAML::EndMap;
  }
  out << YAML::EndSeq << YAML::Key << "writes" << YAML::Value << YAML::BeginSeq;
  for (const ChannelUse& u : outputs_) {
    out << YAML::Flow << YAML::BeginMap << YAML::Key << "channel" << YAML::Value << u.channel
        << YAML::Key << "bus" << YAML::Value << toString(homeBus(u.channel)) << YAML::EndMap;
  }
  out << YAML::EndSeq << YAML::Key << "links" << YAML::Value << YAML::BeginSeq;
  for (const Link& l : links_) {
    out << YAML::Flow << YAML::BeginMap << YAML::Key << "kind" << YAML::Value << l.kind << YAML::Key
        << "name" << YAML::Value << l.name << YAML::Key << "direction" << YAML::Value
        << toString(l.direction) << YAML::EndMap;
  }
  out << YAML::EndSeq << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

ProcessIo parseProcessIo(const std::string& text, const std::string& origin) {
  // What follows the last marker (log lines may come before it).
  const std::size_t marker = text.rfind(kIoMarker);
  const std::string yaml = marker == std::string::npos ? text : text.substr(marker);
  const config::Node root = config::Node::loadString(yaml, origin);
  ProcessIo io(root.get<std::string>("process"));
  const auto use = [&](const config::Node& n, bool input) {
    ChannelUse u;
    u.channel = n.get<std::string>("channel");
    if (!knownChannel(u.channel)) n.fail("channel", "'" + u.channel + "' is no channel");
    (void)n.getChoice("bus", {"robot", "sim"});
    if (input) {
      u.required = n.get<bool>("required");
      u.every_robot = n.get<bool>("every_robot");
    }
    n.rejectUnknownKeys();
    return u;
  };
  try {
    for (const config::Node& n : root.children("reads"))
      io.addInput(use(n, true));
    for (const config::Node& n : root.children("writes"))
      io.addOutput(use(n, false));
  } catch (const std::logic_error& e) {
    throw config::Error(origin + ": " + e.what());
  }
  for (const config::Node& n : root.children("links")) {
    const std::string kind = n.get<std::string>("kind");
    const std::string name = n.get<std::string>("name");
    io.link(kind, name, directionOf(n.getChoice("direction", {"in", "out", "both"})));
    n.rejectUnknownKeys();
  }
  root.rejectUnknownKeys();
  return io;
}

int printIo(const ProcessIo& io) {
  // Log lines printed before (the process logs to stdout) stay above the marker.
  std::fflush(stdout);
  std::fputs((std::string(kIoMarker) + "\n" + io.toYaml()).c_str(), stdout);
  std::fflush(stdout);
  return 0;
}

}  // namespace fieldline::bus
