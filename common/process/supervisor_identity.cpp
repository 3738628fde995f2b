#include "common/process/supervisor_identity.hpp"

#include <unistd.h>

#include <fstream>
#include <sstream>

#include <fmt/format.h>

namespace fieldline::process {
namespace {

std::string firstLine(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  return line;
}

}  // namespace

std::string supervisorIdentity() {
  const std::string boot = firstLine("/proc/sys/kernel/random/boot_id");
  const pid_t parent = ::getppid();
  const std::string stat = firstLine("/proc/" + std::to_string(parent) + "/stat");
  // Field 22 (starttime) counted after the command name, which may hold spaces and parentheses.
  const auto close = stat.rfind(')');
  if (boot.empty() || close == std::string::npos || close + 2 > stat.size()) return {};
  std::istringstream fields(stat.substr(close + 2));
  std::string field;
  for (int k = 3; k <= 22 && fields >> field; ++k) {
    if (k == 22) return fmt::format("boot {} pid {} started {}", boot, parent, field);
  }
  return {};
}

}  // namespace fieldline::process
