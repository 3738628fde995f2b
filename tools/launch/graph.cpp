#include "tools/launch/graph.hpp"

#include <algorithm>
#include <map>
#include <set>

#include <sys/wait.h>

#include <fmt/format.h>

#include "common/config/config.hpp"

namespace fieldline::launch {
namespace {

std::string busName(int bus) {
  return bus == kSimRobot ? "the simulator's bus" : fmt::format("robot {}'s bus", bus);
}

// Every robot bus of the launch (a monitor's every-robot inputs are read on each).
std::set<int> robotBuses(const std::vector<InstanceIo>& nodes) {
  std::set<int> buses;
  for (const InstanceIo& n : nodes) {
    if (n.instance.robot != kSimRobot) buses.insert(n.instance.robot);
  }
  return buses;
}

// The buses `node` reads `use` on.
std::set<int> readBuses(const InstanceIo& node, const bus::ChannelUse& use,
                        const std::set<int>& robot_buses) {
  if (bus::homeBus(use.channel) == bus::BusKind::kSim) return {kSimRobot};
  if (use.every_robot) return robot_buses;
  return {node.instance.robot};
}

// The bus `node` writes `channel` on.
int writeBus(const InstanceIo& node, const std::string& channel) {
  return bus::homeBus(channel) == bus::BusKind::kSim ? kSimRobot : node.instance.robot;
}

std::vector<const InstanceIo*> writersOf(const std::vector<InstanceIo>& nodes,
                                         const std::string& channel, int bus) {
  std::vector<const InstanceIo*> found;
  for (const InstanceIo& n : nodes) {
    // SERVICE_STATUS: every process, on its own bus.
    if (n.io.writesChannel(channel) && writeBus(n, channel) == bus) found.push_back(&n);
  }
  return found;
}

std::vector<const InstanceIo*> readersOf(const std::vector<InstanceIo>& nodes,
                                         const std::string& channel, int bus,
                                         const std::set<int>& robot_buses) {
  std::vector<const InstanceIo*> found;
  for (const InstanceIo& n : nodes) {
    for (const bus::ChannelUse& u : n.io.inputs()) {
      if (u.channel == channel && readBuses(n, u, robot_buses).contains(bus)) found.push_back(&n);
    }
  }
  return found;
}

// "r1-r3", "r1, r4", "sim".
std::string robotList(std::vector<int> robots) {
  std::sort(robots.begin(), robots.end());
  robots.erase(std::unique(robots.begin(), robots.end()), robots.end());
  std::string out;
  for (std::size_t i = 0; i < robots.size();) {
    std::size_t j = i;
    while (j + 1 < robots.size() && robots[j + 1] == robots[j] + 1 && robots[i] != kSimRobot)
      ++j;
    if (!out.empty()) out += ", ";
    out += robotLabel(robots[i]);
    if (j > i) out += (j == i + 1 ? ", " : "-") + robotLabel(robots[j]);
    i = j + 1;
  }
  return out;
}

// The processes of `list` by name; an instance on `here` (the bus being shown) by its name alone.
std::string who(const std::vector<const InstanceIo*>& list, int here) {
  std::vector<std::string> names;
  std::map<std::string, std::vector<int>> robots;
  for (const InstanceIo* n : list) {
    if (!robots.contains(n->instance.name)) names.push_back(n->instance.name);
    robots[n->instance.name].push_back(n->instance.robot);
  }
  std::string out;
  for (const std::string& name : names) {
    const std::vector<int>& r = robots[name];
    if (!out.empty()) out += ", ";
    out += r.size() == 1 && r.front() == here ? name : name + " (" + robotList(r) + ")";
  }
  return out;
}

void formatNode(std::string& out, const std::vector<InstanceIo>& nodes, const InstanceIo& node,
                const std::set<int>& robot_buses) {
  const int here = node.instance.robot;
  out += "  " + node.instance.name + "\n";
  if (node.io.inputs().empty() && node.io.outputs().empty() && node.io.links().empty()) {
    out += "    (reads and writes no channel)\n";
  }
  for (const bus::ChannelUse& u : node.io.inputs()) {
    std::vector<const InstanceIo*> from;
    std::vector<int> buses;
    for (int b : readBuses(node, u, robot_buses)) {
      buses.push_back(b);
      for (const InstanceIo* w : writersOf(nodes, u.channel, b))
        from.push_back(w);
    }
    std::string where;
    if (u.every_robot) where = " on " + robotList(buses);
    if (bus::homeBus(u.channel) == bus::BusKind::kSim && here != kSimRobot) where = " (sim bus)";
    const std::string source = from.empty()                                      ? "nobody"
                               : u.channel == bus::channels::kServiceStatus.name ? "every process"
                                                                                 : who(from, here);
    out += fmt::format("    reads  {:<20} <- {}{}\n", u.channel + where, source,
                       u.required ? "" : "  (used when present)");
  }
  for (const bus::ChannelUse& u : node.io.outputs()) {
    const int b = writeBus(node, u.channel);
    const auto to = readersOf(nodes, u.channel, b, robot_buses);
    const std::string where =
        bus::homeBus(u.channel) == bus::BusKind::kSim && here != kSimRobot ? " (sim bus)" : "";
    out += fmt::format("    writes {:<20} -> {}\n", u.channel + where,
                       to.empty() ? "nobody in this launch" : who(to, here));
  }
  for (const bus::Link& l : node.io.links()) {
    std::vector<const InstanceIo*> peers;
    for (const InstanceIo& n : nodes) {
      if (&n == &node) continue;
      for (const bus::Link& other : n.io.links()) {
        if (other.kind == l.kind && other.name == l.name) peers.push_back(&n);
      }
    }
    out += fmt::format("    {:<6} {} ({}) <-> {}\n", l.kind, l.name, bus::toString(l.direction),
                       peers.empty() ? "outside the launch" : who(peers, here));
  }
}

}  // namespace

LaunchGraph queryGraph(const LaunchPlan& plan, const PreflightOptions& options) {
  LaunchGraph graph;
  for (const LaunchInstance& i : plan.instances) {
    if (i.path.empty()) graph.skipped.push_back(i.label());
  }
  for (auto& [instance, answer] : askChildren(plan.instances, kPrintIoOption, options)) {
    const int code = WIFEXITED(answer.wait_status) ? WEXITSTATUS(answer.wait_status) : -1;
    if (answer.failed_to_start || answer.timed_out || code != 0) {
      graph.problems.push_back(
          fmt::format("{}: no answer to {} ({}): {}", instance->label(), kPrintIoOption,
                      answer.timed_out ? fmt::format("not within {} s", options.timeout_s)
                                       : fmt::format("exit code {}", code),
                      answer.output));
      continue;
    }
    try {
      graph.nodes.push_back(
          {*instance, bus::parseProcessIo(answer.output, instance->label() + " --print-io")});
    } catch (const config::Error& e) {
      graph.problems.push_back(e.what());
    }
  }
  return graph;
}

std::vector<std::string> missingWriters(const std::vector<InstanceIo>& nodes) {
  const std::set<int> robot_buses = robotBuses(nodes);
  std::vector<std::string> missing;
  for (const InstanceIo& n : nodes) {
    for (const bus::ChannelUse& u : n.io.inputs()) {
      if (!u.required) continue;
      for (int b : readBuses(n, u, robot_buses)) {
        if (writersOf(nodes, u.channel, b).empty()) {
          missing.push_back(fmt::format("{} reads {} on {}: no process of the launch writes it",
                                        n.instance.label(), u.channel, busName(b)));
        }
      }
    }
  }
  return missing;
}

std::string formatGraph(const std::vector<InstanceIo>& nodes) {
  const std::set<int> robot_buses = robotBuses(nodes);
  std::string out =
      "# What every process reads and writes, as each declares it (fieldline-<process> "
      "--print-io).\n# Every process also writes SERVICE_STATUS on its bus (the launcher's "
      "status table).\n";
  int bus = -1;
  for (const InstanceIo& n : nodes) {
    if (n.instance.robot != bus) {
      bus = n.instance.robot;
      const std::string name = bus == kSimRobot ? "sim bus" : fmt::format("robot {} bus", bus);
      out += fmt::format("\n{}  {}\n", name, n.instance.bus_url);
    }
    formatNode(out, nodes, n, robot_buses);
  }
  const std::vector<std::string> missing = missingWriters(nodes);
  out += missing.empty() ? "\nEvery required input has a writer.\n"
                         : "\nRequired inputs without a writer:\n";
  for (const std::string& m : missing)
    out += "  " + m + "\n";
  return out;
}

}  // namespace fieldline::launch
