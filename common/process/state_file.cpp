#include "common/process/state_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace fieldline::process {

void writeStateFile(const std::string& path, const std::string& text) {
  // Per process: two runs sharing the folder must not rename each other's half-written file.
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  {
    std::ofstream out(tmp, std::ios::trunc);
    out << text;
    out.flush();
    if (!out) {
      const std::string why = std::strerror(errno);
      ::unlink(tmp.c_str());
      throw std::runtime_error("cannot write " + tmp + ": " + why);
    }
  }
  // Swapped with the old file, which is then removed, rather than renamed over it: ext4 writes a
  // file renamed over another out to the disk at once (auto_da_alloc): 430-450 us of CPU a save on
  // the development machine's virtual disk against 180-210 us swapped (fusion saves 5 times a
  // second, the simulator 10; the saves were 8 % of fusion's CPU in the team, docs/performance.md).
  // A reader sees the old file or the new one all the same; after a power loss the new one may
  // be empty (not yet written out), which the readers refuse as corrupt. Only a regular file is
  // swapped (a directory at `path` stays where it is and the rename below fails). The first
  // save, and file systems without the exchange, rename.
  std::error_code ec;
  if (std::filesystem::is_regular_file(path, ec) &&
      ::renameat2(AT_FDCWD, tmp.c_str(), AT_FDCWD, path.c_str(), RENAME_EXCHANGE) == 0) {
    ::unlink(tmp.c_str());
    return;
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const std::string why = std::strerror(errno);
    ::unlink(tmp.c_str());
    throw std::runtime_error("cannot rename " + tmp + " to " + path + ": " + why);
  }
}

std::optional<std::string> readStateFile(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return std::nullopt;
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read " + path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace fieldline::process
