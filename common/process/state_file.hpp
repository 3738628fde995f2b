// The small text files a process keeps for its own restart (world_sim's snapshot, fusion's saved
// pose): written whole or not at all (but see writeStateFile on power loss), read back whole.
#pragma once

#include <optional>
#include <string>

namespace fieldline::process {

// Writes `text` to a temporary file of this process beside `path` and swaps it in for `path` in
// one step (the old file is then removed), so a reader, or a process that crashes while saving,
// never sees half of it. Not durable across a power loss: the file may then be empty, which the
// readers refuse as corrupt. Throws std::runtime_error naming the file (no temporary file left).
void writeStateFile(const std::string& path, const std::string& text);

// The whole file; nothing when it does not exist. Throws std::runtime_error when it exists but
// cannot be read.
std::optional<std::string> readStateFile(const std::string& path);

}  // namespace fieldline::process
