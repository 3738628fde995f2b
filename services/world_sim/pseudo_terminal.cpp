#include "services/world_sim/pseudo_terminal.hpp"

#include <fcntl.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <system_error>

namespace fieldline::world_sim {
namespace {

[[noreturn]] void fail(const std::string& what) {
  throw std::runtime_error("pseudo-terminal: " + what + ": " + std::strerror(errno));
}

}  // namespace

PseudoTerminal::PseudoTerminal(std::string link_path) : link_path_(std::move(link_path)) {
  master_ = posix_openpt(O_RDWR | O_NOCTTY | O_NONBLOCK);
  if (master_ < 0) fail("posix_openpt");
  if (grantpt(master_) != 0 || unlockpt(master_) != 0) {
    ::close(master_);
    fail("grantpt/unlockpt");
  }
  char name[128];
  if (ptsname_r(master_, name, sizeof name) != 0) {
    ::close(master_);
    fail("ptsname");
  }
  slave_path_ = name;
  slave_ = ::open(slave_path_.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK);
  if (slave_ < 0) {
    ::close(master_);
    fail("open " + slave_path_);
  }
  // Raw 8-bit line: no echo, no line editing, no CR/LF translation.
  termios tio{};
  tcgetattr(slave_, &tio);
  cfmakeraw(&tio);
  cfsetspeed(&tio, B115200);
  tcsetattr(slave_, TCSANOW, &tio);

  // Replace the link atomically so a reconnecting bridge never sees a half-made one.
  namespace fs = std::filesystem;
  const fs::path link(link_path_);
  std::error_code ec;
  if (link.has_parent_path()) fs::create_directories(link.parent_path(), ec);
  const fs::path tmp = link.string() + ".new";
  fs::remove(tmp, ec);
  fs::create_symlink(slave_path_, tmp, ec);
  if (!ec) fs::rename(tmp, link, ec);
  if (ec) {
    ::close(slave_);
    ::close(master_);
    throw std::runtime_error("pseudo-terminal: cannot link " + link_path_ + " -> " + slave_path_ +
                             ": " + ec.message());
  }
}

PseudoTerminal::~PseudoTerminal() {
  namespace fs = std::filesystem;
  std::error_code ec;
  // Remove the link only if it still points at this pty (a newer one may have replaced it).
  if (fs::is_symlink(link_path_, ec) && fs::read_symlink(link_path_, ec) == slave_path_) {
    fs::remove(link_path_, ec);
  }
  if (slave_ >= 0) ::close(slave_);
  if (master_ >= 0) ::close(master_);
}

std::size_t PseudoTerminal::read(std::vector<std::uint8_t>& out) {
  std::size_t total = 0;
  std::uint8_t buffer[512];
  for (;;) {
    const ssize_t n = ::read(master_, buffer, sizeof buffer);
    if (n <= 0) break;
    out.insert(out.end(), buffer, buffer + n);
    total += static_cast<std::size_t>(n);
  }
  return total;
}

std::size_t PseudoTerminal::write(std::span<const std::uint8_t> bytes) {
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(master_, bytes.data() + done, bytes.size() - done);
    if (n <= 0) break;
    done += static_cast<std::size_t>(n);
  }
  return bytes.size() - done;
}

}  // namespace fieldline::world_sim
