// The restart state files (common/process/state_file.hpp): whole files in, whole files out, and
// no temporary file left behind, whichever way a save ends.
#include "common/process/state_file.hpp"

#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

namespace fieldline::process {
namespace {

namespace fs = std::filesystem;

class StateFile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("fieldline_state_file_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  int entries() const {
    int n = 0;
    for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir_))
      ++n;
    return n;
  }
  fs::path dir_;
};

TEST_F(StateFile, TheFirstSaveCreatesTheFileAndLaterSavesReplaceItWhole) {
  const std::string path = (dir_ / "fusion1.pose").string();
  EXPECT_FALSE(readStateFile(path).has_value());
  writeStateFile(path, "first save, the longer of the two\n");
  EXPECT_EQ(readStateFile(path).value(), "first save, the longer of the two\n");
  writeStateFile(path, "second\n");
  EXPECT_EQ(readStateFile(path).value(), "second\n");
  EXPECT_EQ(entries(), 1) << "a temporary or swapped-out file was left beside the state file";
}

TEST_F(StateFile, ADirectoryInThePlaceOfTheFileIsRefusedAndLeftWhereItIs) {
  const fs::path path = dir_ / "snapshot";
  fs::create_directories(path / "inside");
  EXPECT_THROW(writeStateFile(path.string(), "text"), std::runtime_error);
  EXPECT_TRUE(fs::is_directory(path / "inside"));
  EXPECT_EQ(entries(), 1) << "the temporary file was left behind";
}

TEST_F(StateFile, AFolderThatCannotBeWrittenIsReportedWithTheFileName) {
  const std::string path = (dir_ / "missing" / "fusion1.pose").string();
  try {
    writeStateFile(path, "text");
    FAIL() << "no error for a folder that does not exist";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("fusion1.pose"), std::string::npos) << e.what();
  }
  EXPECT_EQ(entries(), 0);
}

TEST_F(StateFile, AWriterReplacesTheFileWholeAndLeavesNothingBesideItWhenGone) {
  const std::string path = (dir_ / "fusion1.pose").string();
  {
    StateFileWriter writer(path);
    for (const std::string text : {"first save, the longer of the two\n", "second\n",
                                   "third, longer than the second\n", "4\n"}) {
      writer.write(text);
      EXPECT_EQ(readStateFile(path).value(), text);
    }
    // The temporary file, kept for the next save.
    EXPECT_LE(entries(), 2);
  }
  EXPECT_EQ(readStateFile(path).value(), "4\n");
  EXPECT_EQ(entries(), 1) << "the writer's temporary file was left beside the state file";
}

TEST_F(StateFile, AWriterRemovesTheTemporaryFilesOfProcessesThatNoLongerRun) {
  const std::string path = (dir_ / "fusion1.pose").string();
  const pid_t child = ::fork();
  if (child == 0) ::_exit(0);
  ASSERT_GT(child, 0);
  ASSERT_EQ(::waitpid(child, nullptr, 0), child);
  const std::string dead = path + ".tmp." + std::to_string(child);
  const std::string alive = path + ".tmp." + std::to_string(::getppid());
  const std::string other = (dir_ / "other.tmp.1").string();
  for (const std::string& f : {dead, alive, other})
    std::ofstream(f) << "left\n";
  {
    StateFileWriter writer(path);
    EXPECT_FALSE(fs::exists(dead));
    EXPECT_TRUE(fs::exists(alive));
    EXPECT_TRUE(fs::exists(other));
    writer.write("saved\n");
  }
  EXPECT_EQ(readStateFile(path).value(), "saved\n");
  EXPECT_EQ(entries(), 3);
}

TEST_F(StateFile, AWriterRefusesADirectoryInThePlaceOfTheFileAndAMissingFolder) {
  const fs::path folder = dir_ / "snapshot";
  fs::create_directories(folder / "inside");
  {
    StateFileWriter writer(folder.string());
    EXPECT_THROW(writer.write("text"), std::runtime_error);
    EXPECT_TRUE(fs::is_directory(folder / "inside"));
    EXPECT_EQ(entries(), 1) << "the temporary file was left behind";
  }
  StateFileWriter missing((dir_ / "missing" / "fusion1.pose").string());
  try {
    missing.write("text");
    FAIL() << "no error for a folder that does not exist";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("fusion1.pose"), std::string::npos) << e.what();
  }
  EXPECT_EQ(entries(), 1);
}

}  // namespace
}  // namespace fieldline::process
