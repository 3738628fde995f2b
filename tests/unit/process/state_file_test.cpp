// The restart state files (common/process/state_file.hpp): whole files in, whole files out, and
// no temporary file left behind, whichever way a save ends.
#include "common/process/state_file.hpp"

#include <sched.h>
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
  // The temporary file of the writer of `path` in process `pid` (`path`.tmp.PID.N; N counts the
  // writers in that process), or `path`.tmp.PID.? when there is none.
  std::string temporaryOf(const std::string& path, pid_t pid) const {
    const std::string prefix =
        fs::path(path).filename().string() + ".tmp." + std::to_string(pid) + ".";
    for (const auto& e : fs::directory_iterator(dir_)) {
      if (e.path().filename().string().rfind(prefix, 0) == 0) return e.path().string();
    }
    return path + ".tmp." + std::to_string(pid) + ".?";
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

// A writer with its temporary file beside `path` (the second save leaves one: the first
// renames), in a child process. The parent reads a byte from ready() once the child's second
// save is done (false: the child ended before it). With `crash` the child then ends without its
// destructor (as at a crash, SIGKILL); else it runs until release().
class ChildWriter {
 public:
  ChildWriter(const std::string& path, bool crash) {
    int ready[2] = {-1, -1}, release[2] = {-1, -1};
    if (::pipe(ready) != 0 || ::pipe(release) != 0) return;
    pid_ = ::fork();
    if (pid_ == 0) {
      ::close(ready[0]);
      ::close(release[1]);
      StateFileWriter* writer = new StateFileWriter(path);
      writer->write("child's first\n");
      writer->write("child's second\n");
      const char c = 1;
      if (::write(ready[1], &c, 1) != 1) ::_exit(2);
      if (crash) ::_exit(0);
      char r = 0;
      while (::read(release[0], &r, 1) > 0) {
      }
      delete writer;
      ::_exit(0);
    }
    ::close(ready[1]);
    ::close(release[0]);
    ready_ = ready[0];
    release_ = release[1];
  }
  ~ChildWriter() {
    release();
    if (ready_ >= 0) ::close(ready_);
  }
  pid_t pid() const { return pid_; }
  bool ready() {
    char c = 0;
    return ready_ >= 0 && ::read(ready_, &c, 1) == 1;
  }
  // Lets the child end and waits for it: its exit status (-1: none).
  int release() {
    if (release_ >= 0) ::close(release_);
    release_ = -1;
    int status = 0;
    if (pid_ <= 0 || ::waitpid(pid_, &status, 0) != pid_) return -1;
    pid_ = -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }

 private:
  pid_t pid_ = -1;
  int ready_ = -1, release_ = -1;
};

// `run` in a child process that is PID 1 of a new PID namespace (what it returns is the exit
// status). Without CAP_SYS_ADMIN the PID namespace comes inside a new user namespace (which most
// kernels let anyone make); -1 only when neither can be made.
int inNewPidNamespace(int (*run)(const std::string&), const std::string& path) {
  const pid_t child = ::fork();
  if (child == 0) {
    if (::unshare(CLONE_NEWPID) != 0 && ::unshare(CLONE_NEWUSER | CLONE_NEWPID) != 0) ::_exit(77);
    const pid_t inner = ::fork();
    if (inner == 0) ::_exit(run(path));
    int status = 0;
    if (inner < 0 || ::waitpid(inner, &status, 0) != inner || !WIFEXITED(status)) ::_exit(78);
    ::_exit(WEXITSTATUS(status));
  }
  int status = 0;
  if (child < 0 || ::waitpid(child, &status, 0) != child || !WIFEXITED(status)) return 78;
  return WEXITSTATUS(status) == 77 ? -1 : WEXITSTATUS(status);
}

// The sweep keeps a live writer's temporary file and removes one that no writer holds, whatever
// the PID in its name: a crashed writer's, and a file left unlocked (an older build's, or a
// writer gone) whose name has a PID that runs here (until 2026-12-07 the sweep asked kill(PID, 0)
// and kept this one: session 12 finding 4).
TEST_F(StateFile, AWriterRemovesTheTemporaryFilesThatNoWriterHolds) {
  const std::string path = (dir_ / "fusion1.pose").string();
  // The live writer first: the other child's sweep must keep its temporary file too.
  ChildWriter live(path, false);
  ASSERT_GT(live.pid(), 0);
  ASSERT_TRUE(live.ready());
  ChildWriter crashed(path, true);
  const pid_t dead = crashed.pid();
  ASSERT_GT(dead, 0);
  ASSERT_TRUE(crashed.ready());
  ASSERT_EQ(crashed.release(), 0);
  const std::string dead_tmp = temporaryOf(path, dead);
  const std::string live_tmp = temporaryOf(path, live.pid());
  const std::string unlocked = path + ".tmp." + std::to_string(::getppid());
  const std::string other = (dir_ / "other.tmp.1").string();
  for (const std::string& f : {unlocked, other})
    std::ofstream(f) << "left\n";
  ASSERT_TRUE(fs::exists(live_tmp)) << "the live writer has no temporary file";
  ASSERT_TRUE(fs::exists(dead_tmp)) << "the crashed writer left no temporary file";
  {
    StateFileWriter writer(path);
    EXPECT_FALSE(fs::exists(dead_tmp));
    EXPECT_TRUE(fs::exists(live_tmp)) << "a live writer's temporary file was removed";
    EXPECT_FALSE(fs::exists(unlocked)) << "a temporary no writer holds was kept for its PID";
    EXPECT_TRUE(fs::exists(other));
    writer.write("saved\n");
  }
  EXPECT_EQ(live.release(), 0);
  EXPECT_FALSE(fs::exists(live_tmp)) << "the live writer left its temporary file when it ended";
  EXPECT_EQ(readStateFile(path).value(), "saved\n");
  EXPECT_EQ(entries(), 2);  // the file and other.tmp.1
}

// Across PID namespaces (each robot's processes may run in their own): a writer in another
// namespace sweeping the folder keeps this writer's temporary file although this PID does not
// exist there, and a writer here removes the temporary of a writer that was PID 1 of another
// namespace and crashed (PID 1 here is alive). Both failed with the kill(PID, 0) sweep.
int sweepAndReport(const std::string& path) {
  StateFileWriter writer(path);  // its sweep; nothing written
  (void)writer;
  return 0;
}
int crashAfterTwoSaves(const std::string& path) {
  StateFileWriter* writer = new StateFileWriter(path);  // never destroyed, as at a crash
  writer->write("first\n");
  writer->write("second\n");
  return 0;
}

TEST_F(StateFile, TheSweepHoldsAcrossPidNamespaces) {
  const std::string path = (dir_ / "fusion2.pose").string();
  {
    StateFileWriter writer(path);
    writer.write("first\n");
    writer.write("second\n");
    const std::string mine = temporaryOf(path, ::getpid());
    ASSERT_TRUE(fs::exists(mine));
    const int swept = inNewPidNamespace(sweepAndReport, path);
    if (swept < 0)
      GTEST_SKIP() << "no PID namespace for this process (neither CAP_SYS_ADMIN nor user "
                      "namespaces)";
    EXPECT_EQ(swept, 0);
    EXPECT_TRUE(fs::exists(mine))
        << "a writer in another PID namespace removed this live writer's temporary file";
    writer.write("third\n");
    EXPECT_EQ(readStateFile(path).value(), "third\n");
  }
  EXPECT_EQ(entries(), 1);
  const std::string other = (dir_ / "fusion3.pose").string();
  ASSERT_EQ(inNewPidNamespace(crashAfterTwoSaves, other), 0);
  const std::string crashed = temporaryOf(other, 1);
  ASSERT_TRUE(fs::exists(crashed)) << "the writer that was PID 1 left no temporary file";
  ASSERT_EQ(readStateFile(other).value(), "second\n");
  {
    StateFileWriter writer(other);
    EXPECT_FALSE(fs::exists(crashed))
        << "the temporary of a crashed writer in another namespace was kept (PID 1 runs here)";
  }
  EXPECT_EQ(entries(), 2);
}

// Two writers of one file in one process (or writeStateFile beside a StateFileWriter) each have
// a temporary of their own: no save waits for the other's lock (review of session 12: with one
// `path`.tmp.PID per process the second writer waited 200 ms a save and then threw).
TEST_F(StateFile, TwoWritersOfOneFileInOneProcessDoNotWaitForEachOther) {
  const std::string path = (dir_ / "fusion4.pose").string();
  StateFileWriter first(path);
  StateFileWriter second(path);
  first.write("one\n");
  EXPECT_NO_THROW(second.write("two\n"));
  EXPECT_NO_THROW(writeStateFile(path, "three\n"));
  EXPECT_NO_THROW(first.write("four\n"));
  EXPECT_EQ(readStateFile(path).value(), "four\n");
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
