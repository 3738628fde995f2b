// Who started this process: its parent (the launcher, systemd) in this boot. State a process
// saves for its own restart (world_sim's snapshot, fusion's pose) is used only under the same
// identity: a restart by the same supervisor matches, a new launcher or a reboot does not.
#pragma once

#include <string>

namespace fieldline::process {

// "boot <boot id> pid <parent's pid> started <parent's start time>"; empty when /proc cannot
// tell.
std::string supervisorIdentity();

}  // namespace fieldline::process
