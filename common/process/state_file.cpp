#include "common/process/state_file.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string_view>
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

// Whether the open file `fd` is the one named `name` (not a link to it, not another file put
// there since).
bool namedBy(int fd, const std::string& name) {
  struct stat held {};
  struct stat named {};
  return ::fstat(fd, &held) == 0 && ::lstat(name.c_str(), &named) == 0 &&
         held.st_dev == named.st_dev && held.st_ino == named.st_ino;
}

// The temporary file `tmp` opened for writing (created when absent) with its flock taken: a
// writer keeps the lock while the file is its own, and a sweep (StateFileWriter's constructor)
// removes only a temporary whose lock it can take. The lock is on the file, not on a process
// number, so it holds in every PID namespace that shares the folder. Retried while the lock is
// held for a moment (a sweep found the file stale and is removing it) or the name was removed
// between the open and the lock. A link at the name is refused (O_NOFOLLOW), never written
// through. Throws std::runtime_error naming the file.
int openLockedTemporary(const std::string& tmp) {
  for (int attempt = 0;; ++attempt) {
    // O_NONBLOCK: a FIFO put at the name must not hang the writer until a reader comes.
    const int fd =
        ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK, 0666);
    if (fd < 0) {
      const std::string why = std::strerror(errno);
      throw std::runtime_error("cannot write " + tmp + ": " + why);
    }
    struct stat kind {};
    if (::fstat(fd, &kind) != 0 || !S_ISREG(kind.st_mode)) {
      ::close(fd);
      throw std::runtime_error("cannot write " + tmp + ": not a regular file");
    }
    if (::flock(fd, LOCK_EX | LOCK_NB) == 0) {
      if (namedBy(fd, tmp)) return fd;
    } else if (errno != EWOULDBLOCK && errno != EINTR) {
      const std::string why = std::strerror(errno);
      ::close(fd);
      throw std::runtime_error("cannot lock " + tmp + ": " + why);
    }
    ::close(fd);
    if (attempt == 200) {
      throw std::runtime_error("cannot write " + tmp + ": another process holds its lock");
    }
    const timespec pause{0, 1'000'000};  // 1 ms: a sweep holds the lock for microseconds
    ::nanosleep(&pause, nullptr);
  }
}

// Writes `text` over the file `fd` from its start and cuts what was beyond; 0 or the error.
int writeWhole(int fd, const std::string& text) {
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
  return error;
}

// A temporary file name of its own for each writer: `path`.tmp.PID.N. Per process, so that two
// runs sharing the folder never rename each other's half-written file, and per writer (N counts
// in the process), so that two writers of one file in one process never wait for each other's
// lock (a flock taken through another open() holds against the same process too).
std::string temporaryName(const std::string& path) {
  static std::atomic<unsigned> next{0};
  return path + ".tmp." + std::to_string(::getpid()) + "." + std::to_string(next++);
}

}  // namespace

void writeStateFile(const std::string& path, const std::string& text) {
  const std::string tmp = temporaryName(path);
  const int fd = openLockedTemporary(tmp);
  const int error = writeWhole(fd, text);
  if (error != 0) {
    ::unlink(tmp.c_str());
    ::close(fd);
    throw std::runtime_error("cannot write " + tmp + ": " + std::strerror(error));
  }
  // The old file, swapped out, is removed. After a power loss the new one may be empty (not yet
  // written out), which the readers refuse as corrupt. The lock is held until the name is gone.
  try {
    if (swapIn(tmp, path)) ::unlink(tmp.c_str());
  } catch (...) {
    ::close(fd);
    throw;
  }
  ::close(fd);
}

namespace {

// `name` is `base`.tmp.PID.N, or `base`.tmp.PID of older builds (a temporary file of a writer of
// `base`).
bool temporaryOf(const std::string& name, const std::string& base) {
  const std::string prefix = base + ".tmp.";
  if (name.size() <= prefix.size() || name.compare(0, prefix.size(), prefix) != 0) return false;
  const auto number = [](std::string_view digits) {
    return !digits.empty() && digits.size() <= 10 &&
           std::all_of(digits.begin(), digits.end(),
                       [](unsigned char c) { return std::isdigit(c); });
  };
  const std::string_view rest = std::string_view(name).substr(prefix.size());
  const std::size_t dot = rest.find('.');
  if (dot == std::string_view::npos) return number(rest);
  return number(rest.substr(0, dot)) && number(rest.substr(dot + 1));
}

// Removes the temporary file `file` when its lock can be taken: no writer holds it, whichever
// PID namespace the writer ran in (it crashed, was killed, or was an older build's that locked
// nothing). A link, or anything but a regular file, is left.
void removeIfStale(const std::string& file) {
  const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK);
  if (fd < 0) return;
  struct stat st {};
  if (::fstat(fd, &st) == 0 && S_ISREG(st.st_mode) && ::flock(fd, LOCK_EX | LOCK_NB) == 0 &&
      namedBy(fd, file)) {
    ::unlink(file.c_str());
  }
  ::close(fd);
}

}  // namespace

StateFileWriter::StateFileWriter(std::string path)
    : path_(std::move(path)), tmp_(temporaryName(path_)) {
  // Errors here only leave stale files where they were.
  namespace fs = std::filesystem;
  const fs::path file(path_);
  const fs::path folder = file.has_parent_path() ? file.parent_path() : fs::path(".");
  const std::string base = file.filename().string();
  std::error_code ec;
  for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
    if (temporaryOf(it->path().filename().string(), base)) removeIfStale(it->path().string());
  }
}

StateFileWriter::~StateFileWriter() {
  if (tmp_fd_ >= 0 && namedBy(tmp_fd_, tmp_)) ::unlink(tmp_.c_str());
  if (tmp_fd_ >= 0) {
    ::close(tmp_fd_);
  } else {
    removeIfStale(tmp_);  // a previous save not taken again after its swap (see write)
  }
}

void StateFileWriter::write(const std::string& text) {
  // The temporary file is this writer's while it holds it open and locked. Written over in place:
  // no O_TRUNC (ext4 also flushes a file truncated to nothing and rewritten when it is closed,
  // auto_da_alloc), the tail cut after the write instead.
  if (tmp_fd_ >= 0 && !namedBy(tmp_fd_, tmp_)) {
    ::close(tmp_fd_);
    tmp_fd_ = -1;
  }
  if (tmp_fd_ < 0) tmp_fd_ = openLockedTemporary(tmp_);
  const int error = writeWhole(tmp_fd_, text);
  if (error != 0) {
    ::unlink(tmp_.c_str());
    ::close(tmp_fd_);
    tmp_fd_ = -1;
    throw std::runtime_error("cannot write " + tmp_ + ": " + std::strerror(error));
  }
  bool swapped = false;
  try {
    swapped = swapIn(tmp_, path_);
  } catch (...) {
    ::close(tmp_fd_);
    tmp_fd_ = -1;
    throw;
  }
  // The file written is the state file now: closed, its lock goes (no lock is kept on a file at
  // the path, which another writer's swap may make its temporary). Swapped, the temporary name
  // holds the previous save, written over by the next one: taken and locked again at once (a
  // failure here is the next write's).
  ::close(tmp_fd_);
  tmp_fd_ = -1;
  if (swapped) {
    try {
      tmp_fd_ = openLockedTemporary(tmp_);
    } catch (const std::runtime_error&) {
    }
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
