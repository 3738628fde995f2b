#include "common/process/state_file.hpp"

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace fieldline::process {

namespace {

// Puts the written temporary file `tmp` in place of `path`. Swapped with the old file rather than
// renamed over it: ext4 writes a file renamed over another out to the disk at once
// (auto_da_alloc): 430-450 us of CPU a save on the development machine's virtual disk against
// 180-210 us swapped (fusion saves 5 times a second, the simulator 10; the saves were 8 % of
// fusion's CPU in the team, docs/performance.md). A reader sees the old file or the new one all
// the same. Only a regular file is swapped (a directory at `path` stays where it is and the rename
// fails). The first save, and file systems without the exchange, rename. Returns true when swapped
// (`tmp` then holds the old file); throws, leaving no `tmp`, when neither works.
bool swapIn(const std::string& tmp, const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_regular_file(path, ec) &&
      ::renameat2(AT_FDCWD, tmp.c_str(), AT_FDCWD, path.c_str(), RENAME_EXCHANGE) == 0) {
    return true;
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const std::string why = std::strerror(errno);
    ::unlink(tmp.c_str());
    throw std::runtime_error("cannot rename " + tmp + " to " + path + ": " + why);
  }
  return false;
}

}  // namespace

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
  // The old file, swapped out, is removed. After a power loss the new one may be empty (not yet
  // written out), which the readers refuse as corrupt.
  if (swapIn(tmp, path)) ::unlink(tmp.c_str());
}

namespace {

// `name` is `base`.tmp.PID for a process that no longer runs.
bool staleTemporary(const std::string& name, const std::string& base) {
  const std::string prefix = base + ".tmp.";
  if (name.size() <= prefix.size() || name.compare(0, prefix.size(), prefix) != 0) return false;
  const std::string digits = name.substr(prefix.size());
  if (digits.size() > 9 ||
      !std::all_of(digits.begin(), digits.end(), [](unsigned char c) { return std::isdigit(c); }))
    return false;
  const pid_t pid = static_cast<pid_t>(std::stol(digits));
  return pid > 0 && pid != ::getpid() && ::kill(pid, 0) != 0 && errno == ESRCH;
}

}  // namespace

StateFileWriter::StateFileWriter(std::string path)
    : path_(std::move(path)), tmp_(path_ + ".tmp." + std::to_string(::getpid())) {
  // Errors here only leave stale files where they were.
  namespace fs = std::filesystem;
  const fs::path file(path_);
  const fs::path folder = file.has_parent_path() ? file.parent_path() : fs::path(".");
  const std::string base = file.filename().string();
  std::error_code ec;
  for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (staleTemporary(name, base) && it->is_regular_file(ec)) fs::remove(it->path(), ec);
  }
}

StateFileWriter::~StateFileWriter() {
  ::unlink(tmp_.c_str());
}

void StateFileWriter::write(const std::string& text) {
  // Written over in place: no O_TRUNC (ext4 also flushes a file truncated to nothing and
  // rewritten when it is closed, auto_da_alloc), the tail cut after the write instead.
  // O_NOFOLLOW: a link put at the temporary name is refused, never written through.
  const int fd = ::open(tmp_.c_str(), O_WRONLY | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0666);
  if (fd < 0) {
    const std::string why = std::strerror(errno);
    throw std::runtime_error("cannot write " + tmp_ + ": " + why);
  }
  int error = 0;
  for (std::size_t done = 0; done < text.size() && error == 0;) {
    const ssize_t n =
        ::pwrite(fd, text.data() + done, text.size() - done, static_cast<off_t>(done));
    if (n > 0) {
      done += static_cast<std::size_t>(n);
    } else if (n == 0 || errno != EINTR) {
      error = n == 0 ? EIO : errno;
    }
  }
  if (error == 0 && ::ftruncate(fd, static_cast<off_t>(text.size())) != 0) error = errno;
  if (::close(fd) != 0 && error == 0) error = errno;
  if (error != 0) {
    ::unlink(tmp_.c_str());
    throw std::runtime_error("cannot write " + tmp_ + ": " + std::strerror(error));
  }
  // Swapped in, the temporary file holds the previous save, written over by the next one.
  swapIn(tmp_, path_);
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
