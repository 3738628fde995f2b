#include "tools/calibration_common/staged_output.hpp"

#include <fstream>
#include <system_error>

#include <unistd.h>

namespace fieldline::calibration {

namespace fs = std::filesystem;

StagedFiles::~StagedFiles() {
  if (folder_.empty()) return;
  std::error_code ignored;
  fs::remove_all(folder_, ignored);
}

std::string StagedFiles::stage(const std::string& destination, const std::string& content) {
  const fs::path target = fs::absolute(fs::path(destination)).lexically_normal();
  const fs::path dir = target.parent_path();
  if (target.filename().empty()) throw std::runtime_error(destination + ": not a file name");
  if (folder_.empty()) {
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) {
      throw std::runtime_error(destination + ": the folder " + dir.string() + " does not exist");
    }
    folder_ = dir / (".fieldline-staging-" + std::to_string(::getpid()));
    fs::remove_all(folder_, ec);
    if (!fs::create_directory(folder_, ec)) {
      const fs::path failed = folder_;
      folder_.clear();
      throw std::runtime_error("cannot create " + failed.string() + ": " + ec.message());
    }
  } else if (dir != folder_.parent_path()) {
    throw std::runtime_error(destination + ": staged files must share one folder");
  }
  const fs::path staged = folder_ / target.filename();
  std::ofstream out(staged, std::ios::binary);
  out << content;
  out.close();
  if (!out) throw std::runtime_error("cannot write " + staged.string());
  files_.emplace_back(staged, target);
  return staged.string();
}

std::vector<std::string> StagedFiles::commit() {
  std::vector<std::string> written;
  for (const auto& [staged, target] : files_) {
    std::error_code ec;
    fs::rename(staged, target, ec);
    if (ec) throw std::runtime_error("cannot move " + staged.string() + " to " + target.string());
    written.push_back(target.string());
  }
  files_.clear();
  std::error_code ignored;
  fs::remove_all(folder_, ignored);
  folder_.clear();
  return written;
}

}  // namespace fieldline::calibration
