// Fuzzes the launch file parser (tools/launch/launch_file.hpp): any text must parse into a
// launch file that keeps its documented limits, or fail with config::Error naming the problem.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "common/config/config.hpp"
#include "tools/launch/launch_file.hpp"

namespace config = fieldline::config;
namespace launch = fieldline::launch;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const launch::LaunchFile file =
        launch::parseLaunchFile(config::Node::loadString(text, "fuzz_launch.yaml"));
    for (const auto& process : file.processes) {
      if (process.name.empty() || process.executable.empty()) std::abort();
      for (int robot : process.robots) {
        if (robot < launch::kSimRobot || robot > launch::kMaxRobot) std::abort();
      }
    }
  } catch (const config::Error&) {
  }
  return 0;
}
