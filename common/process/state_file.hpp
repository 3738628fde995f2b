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

// writeStateFile for a file saved again and again by one process (fusion's pose, 5 times a
// second), at about half its CPU: the temporary file is kept between saves, written over in place
// and swapped in, so the file system neither creates nor deletes a file per save (on ext4 that
// was most of a save's cost, docs/performance.md). A reader sees the old file or the new one as
// with writeStateFile, unless it holds the file open across the next save but one (it reads the
// inode that save writes over). The temporary file (`path`.tmp.PID.N) stays beside the file while
// the writer lives, held open with its flock taken; the destructor removes it, and the
// constructor removes the temporaries of `path` whose lock it can take: their writer no longer
// runs (a crash, SIGKILL). The lock, not the PID in the name, says so: a PID means nothing in
// another PID namespace (each robot's processes may run in their own), where a live writer's PID
// can be absent and a dead one's reused. writeStateFile locks its temporary too while it exists.
// After a power loss (not a crash of the process) the file may hold an older save, or a torn one:
// the bytes written over in place are not flushed before the swap. Fusion's pose file does not
// matter then (a new boot refuses the resume). Neither writer here flushes (fsync) before its
// swap: state that must survive a power loss needs that.
class StateFileWriter {
 public:
  explicit StateFileWriter(std::string path);
  ~StateFileWriter();
  StateFileWriter(const StateFileWriter&) = delete;
  StateFileWriter& operator=(const StateFileWriter&) = delete;

  const std::string& path() const { return path_; }
  // As writeStateFile (the same errors); on an error no temporary file is left.
  void write(const std::string& text);

 private:
  std::string path_;
  std::string tmp_;
  // The file at tmp_, open and locked (-1: none, as after the first save, which renames).
  int tmp_fd_ = -1;
};

}  // namespace fieldline::process
