// The small text files a process keeps for its own restart (world_sim's snapshot, fusion's saved
// pose): written whole or not at all, read back whole.
#pragma once

#include <optional>
#include <string>

namespace fieldline::process {

// Writes `text` to a temporary file of this process beside `path` and renames it over `path`, so
// a reader (or a crash) never sees half of it. Throws std::runtime_error naming the file.
void writeStateFile(const std::string& path, const std::string& text);

// The whole file; nothing when it does not exist. Throws std::runtime_error when it exists but
// cannot be read.
std::optional<std::string> readStateFile(const std::string& path);

}  // namespace fieldline::process
