#include "ndsid/common/atomic_file.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "ndsid/common/error.h"

namespace fs = std::filesystem;

namespace ndsid {
namespace {

fs::path FreshDir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("ndsid_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// Catches: a write that leaves the old content, or a temp file lying around after success.
TEST(AtomicFile, ReplacesContentAndLeavesNoTemporary) {
  const fs::path dir = FreshDir("atomic_replace");
  const std::string path = (dir / "state.bin").string();
  WriteFileAtomically(path, "first");
  WriteFileAtomically(path, std::string("second\0binary", 13));
  EXPECT_EQ(ReadWholeFile(path), std::string("second\0binary", 13));
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator{}), 1);
  fs::remove_all(dir);
}

// Catches: a failed write that destroys the previous file (the state we must never lose).
TEST(AtomicFile, FailureLeavesTargetUntouchedAndNamesThePath) {
  const fs::path dir = FreshDir("atomic_fail");
  const std::string path = (dir / "missing_subdir" / "state.bin").string();
  try {
    WriteFileAtomically(path, "x");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("state.bin"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}

TEST(FormatLocation, NamesFileLineColumn) {
  EXPECT_EQ(FormatLocation("a.dbc", 12, 3, "bad"), "a.dbc:12:3: bad");
  EXPECT_EQ(FormatLocation("a.dbc", 0, 0, "bad"), "a.dbc: bad");
}

}  // namespace
}  // namespace ndsid
