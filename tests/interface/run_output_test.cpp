// The output folder's helpers: a file written whole or not at all (WriteWholeFile) and the one-run
// lock on a folder (FolderLock), which RunOutput takes and HeldByAnotherRun tests.
#include "interface/run/run_output.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace cosim::interface {
namespace {

namespace fs = std::filesystem;

// A fresh folder of this test process, removed when it goes out of scope.
class Scratch {
 public:
  explicit Scratch(const std::string& name)
      : path_(fs::temp_directory_path() / (name + "_" + std::to_string(::getpid()))) {
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~Scratch() {
    std::error_code ignored;
    fs::remove_all(path_, ignored);
  }
  Scratch(const Scratch&) = delete;
  Scratch& operator=(const Scratch&) = delete;
  std::string operator/(const std::string& name) const { return (path_ / name).string(); }

 private:
  fs::path path_;
};

std::string Slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(WriteWholeFile, ReplacesTheFileAndLeavesNoTemporary) {
  const Scratch dir("write_whole");
  const std::string path = dir / "index.pvd";
  std::ofstream(path) << "old";
  const WrittenFile written = WriteWholeFile(path, [](std::ostream& out) { out << "new text"; });
  EXPECT_TRUE(written.ok()) << written.why;
  EXPECT_EQ(Slurp(path), "new text");
  EXPECT_FALSE(fs::exists(path + ".part"));
}

// A full disk at the moment of writing (the temporary is a link to /dev/full, so every write fails
// with ENOSPC): the old file stays whole, the link is removed, and the outcome names the file and
// the system's reason.
TEST(WriteWholeFile, AFullDiskLeavesTheOldFileAndNoTemporary) {
  const Scratch dir("write_whole_full");
  const std::string path = dir / "summary.json";
  std::ofstream(path) << "the earlier file";
  fs::create_symlink("/dev/full", path + ".part");
  const WrittenFile written =
      WriteWholeFile(path, [](std::ostream& out) { out << std::string(1 << 20, 'x'); });  // (past any buffer)
  ASSERT_FALSE(written.ok());
  EXPECT_NE(written.why.find("cannot write " + path), std::string::npos) << written.why;
  EXPECT_NE(written.why.find("No space left on device"), std::string::npos) << written.why;
  EXPECT_EQ(Slurp(path), "the earlier file");
  EXPECT_FALSE(fs::exists(fs::symlink_status(path + ".part")));
}

// The writer says its content could not be made (a message that does not serialise): nothing is
// renamed over the file.
TEST(WriteWholeFile, AWriterThatFailsLeavesTheOldFile) {
  const Scratch dir("write_whole_writer");
  const std::string path = dir / "final_state.pb";
  std::ofstream(path) << "state";
  const WrittenFile written = WriteWholeFile(path, [](std::ostream& out) {
    out << "half";
    out.setstate(std::ios::failbit);
  });
  EXPECT_FALSE(written.ok());
  EXPECT_EQ(Slurp(path), "state");
  EXPECT_FALSE(fs::exists(path + ".part"));
}

TEST(WriteWholeFile, AMissingFolderIsNamed) {
  const Scratch dir("write_whole_missing");
  const std::string path = dir / "absent/history_joined.csv";
  const WrittenFile written = WriteWholeFile(path, [](std::ostream& out) { out << "t\n"; });
  ASSERT_FALSE(written.ok());
  EXPECT_NE(written.why.find("cannot write " + path + ": No such file or directory"), std::string::npos) << written.why;
}

// A link at the path is replaced by the file, not written through: OUT/history_joined.csv linked to
// a file elsewhere leaves that file as it was.
TEST(WriteWholeFile, ALinkAtThePathIsReplacedNotWrittenThrough) {
  const Scratch dir("write_whole_link");
  const std::string elsewhere = dir / "elsewhere.txt", path = dir / "history.csv";
  std::ofstream(elsewhere) << "keep";
  fs::create_symlink(elsewhere, path);
  ASSERT_TRUE(WriteWholeFile(path, [](std::ostream& out) { out << "rows"; }).ok());
  EXPECT_EQ(Slurp(elsewhere), "keep");
  EXPECT_FALSE(fs::is_symlink(fs::symlink_status(path)));
  EXPECT_EQ(Slurp(path), "rows");
}

// One holder at a time (flock on the folder, per open descriptor): a second lock on a held folder
// is refused as held by another run, and the folder is free again once the first lock is gone.
TEST(FolderLock, OneHolderAtATimeAndFreeOnceReleased) {
  const Scratch dir("folder_lock");
  const std::string folder = dir / "run";
  fs::create_directories(folder);
  {
    const FolderLock first(folder);
    ASSERT_TRUE(first.taken()) << first.why();
    const FolderLock second(folder);
    EXPECT_EQ(second.outcome(), FolderLock::Outcome::kHeldByAnotherRun);
    EXPECT_TRUE(HeldByAnotherRun(folder));
  }
  EXPECT_FALSE(HeldByAnotherRun(folder));
  EXPECT_TRUE(FolderLock(folder).taken());
}

// HeldByAnotherRun does not follow a link (a link at P/visual to a running run's folder is removed
// as a link, not taken for that run's folder); a missing folder cannot be opened and is not held.
TEST(FolderLock, HeldByAnotherRunLooksAtTheFolderItselfNotALink) {
  const Scratch dir("folder_lock_link");
  const std::string folder = dir / "run", link = dir / "visual";
  fs::create_directories(folder);
  fs::create_directory_symlink(folder, link);
  const FolderLock running(folder);
  ASSERT_TRUE(running.taken());
  EXPECT_TRUE(HeldByAnotherRun(folder));
  EXPECT_FALSE(HeldByAnotherRun(link));
  EXPECT_EQ(FolderLock(link, /*follow_links=*/false).outcome(), FolderLock::Outcome::kCannotOpen);
  const FolderLock absent(dir / "absent");
  EXPECT_EQ(absent.outcome(), FolderLock::Outcome::kCannotOpen);
  EXPECT_NE(absent.why().find("No such file or directory"), std::string::npos) << absent.why();
}

}  // namespace
}  // namespace cosim::interface
