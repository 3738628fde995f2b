// What a calibration tool writes, written only once it has been checked (issue 30, item 3): the
// files are staged in a private folder beside their destination, the tool loads them with the
// loader the services use and checks what it reads, and only then are they moved into place. A
// refused or failed calibration leaves nothing behind: no half-written preset for a robot to load.
#pragma once

#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

namespace fieldline::calibration {

// A calibration that produced nothing useful: the reason is what the tool prints before it exits
// with kRefusedExit (and writes nothing).
class Refusal : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Exit codes shared by the calibration tools: 0 written (or nothing asked to be written), 1 refused
// (the result would be useless; nothing written), 2 bad arguments or config.
inline constexpr int kRefusedExit = 1;
inline constexpr int kBadInputExit = 2;

class StagedFiles {
 public:
  StagedFiles() = default;
  StagedFiles(const StagedFiles&) = delete;
  StagedFiles& operator=(const StagedFiles&) = delete;
  // Removes whatever was staged and not committed.
  ~StagedFiles();

  // Writes `content` under the file name of `destination` into a staging folder in
  // destination's folder (created on first use; all destinations must share one folder) and
  // returns the staged path, which the caller loads and checks. Throws std::runtime_error when
  // the folder cannot be created or the file not written.
  std::string stage(const std::string& destination, const std::string& content);

  // Moves every staged file to its destination (replacing what was there) and removes the
  // staging folder. Returns the destinations.
  std::vector<std::string> commit();

 private:
  std::filesystem::path folder_;
  std::vector<std::pair<std::filesystem::path, std::filesystem::path>> files_;  // staged, final
};

}  // namespace fieldline::calibration
