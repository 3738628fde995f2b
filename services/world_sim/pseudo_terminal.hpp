// A pseudo-terminal that stands in for a robot's serial device: the emulator holds the master
// side, the motor bridge opens the slave through a stable symlink (e.g. /tmp/fieldline/robot1.tty)
// exactly as it would open /dev/ttyUSB0.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace fieldline::world_sim {

class PseudoTerminal {
 public:
  // Opens a new pty in raw mode and points `link_path` at its slave (replacing an old link;
  // creates the link's folder). Throws std::runtime_error with the reason.
  explicit PseudoTerminal(std::string link_path);
  // Closes the pty (the bridge's reads fail, as when a device is unplugged) and removes the link.
  ~PseudoTerminal();
  PseudoTerminal(const PseudoTerminal&) = delete;
  PseudoTerminal& operator=(const PseudoTerminal&) = delete;

  const std::string& slavePath() const { return slave_path_; }
  const std::string& linkPath() const { return link_path_; }
  // Appends the bytes available now (never blocks); returns how many.
  std::size_t read(std::vector<std::uint8_t>& out);
  // Writes what fits now; returns the number of bytes dropped because nobody reads.
  std::size_t write(std::span<const std::uint8_t> bytes);

 private:
  std::string link_path_;
  std::string slave_path_;
  int master_ = -1;
  // Held open so the line keeps its raw settings and the master never sees a hang-up while
  // the bridge reconnects.
  int slave_ = -1;
};

}  // namespace fieldline::world_sim
