#include "ndsid/common/atomic_file.h"

#include <gtest/gtest.h>

#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

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

mode_t ModeOf(const fs::path& p) {
  struct stat st {};
  EXPECT_EQ(::stat(p.c_str(), &st), 0) << p;
  return st.st_mode & 07777;
}

// Sets the process umask for one scope (the umask is process-wide; tests run one at a time).
class ScopedUmask {
 public:
  explicit ScopedUmask(mode_t m) : old_(::umask(m)) {}
  ~ScopedUmask() { ::umask(old_); }

 private:
  mode_t old_;
};

// Catches: new files forced to 0600 (mkstemp's mode), which made every report unreadable to
// anyone but its writer; a new file must get 0666 minus the umask like any other.
TEST(AtomicFile, NewFileFollowsTheUmask) {
  const fs::path dir = FreshDir("atomic_umask");
  for (const auto& [mask, expected] : {std::pair<mode_t, mode_t>{022, 0644}, {027, 0640}, {002, 0664}, {077, 0600}}) {
    ScopedUmask scoped(mask);
    const fs::path p = dir / ("new_" + std::to_string(mask) + ".txt");
    WriteFileAtomically(p.string(), "report");
    EXPECT_EQ(ModeOf(p), expected) << "umask " << std::oct << mask;
  }
  fs::remove_all(dir);
}

// Catches: an edited config rewritten as 0600 (`diagnose --apply` on /etc/ndsid/vehicle.yaml
// then locked out the service's dynamic user) or with the umask's mode instead of its own.
TEST(AtomicFile, ReplacedFileKeepsItsMode) {
  const fs::path dir = FreshDir("atomic_keep_mode");
  ScopedUmask scoped(077);
  for (const mode_t mode : {mode_t{0644}, mode_t{0640}, mode_t{0604}, mode_t{0755}, mode_t{0600}}) {
    const fs::path p = dir / "vehicle.yaml";
    WriteFileAtomically(p.string(), "old");
    ASSERT_EQ(::chmod(p.c_str(), mode), 0);
    WriteFileAtomically(p.string(), "new");
    EXPECT_EQ(ModeOf(p), mode) << std::oct << mode;
    EXPECT_EQ(ReadWholeFile(p.string()), "new");
  }
  fs::remove_all(dir);
}

// Catches: a config edited by root handed over to root (the owner of the old file is lost).
TEST(AtomicFile, ReplacedFileKeepsItsOwnerWhenRoot) {
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to create a file owned by someone else";
  const fs::path dir = FreshDir("atomic_keep_owner");
  const fs::path p = dir / "vehicle.yaml";
  WriteFileAtomically(p.string(), "old");
  ASSERT_EQ(::chown(p.c_str(), 65534, 65534), 0);
  ASSERT_EQ(::chmod(p.c_str(), 0640), 0);
  WriteFileAtomically(p.string(), "new");
  struct stat st {};
  ASSERT_EQ(::stat(p.c_str(), &st), 0);
  EXPECT_EQ(st.st_uid, 65534u);
  EXPECT_EQ(st.st_gid, 65534u);
  EXPECT_EQ(st.st_mode & 07777, 0640u);
  fs::remove_all(dir);
}

// Catches: an unprivileged writer silently taking over a file it may replace (writable folder)
// but not own: the write must fail, naming the file, and leave it as it was.
TEST(AtomicFile, RefusesToChangeTheOwnerWithoutPrivilege) {
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to set up two owners";
  const fs::path dir = FreshDir("atomic_no_takeover");
  const fs::path p = dir / "vehicle.yaml";
  WriteFileAtomically(p.string(), "root's");
  ASSERT_EQ(::chmod(p.c_str(), 0644), 0);
  ASSERT_EQ(::chmod(dir.c_str(), 0777), 0);  // anyone may rename in the folder
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    if (::setgid(65534) != 0 || ::setuid(65534) != 0) ::_exit(3);
    try {
      WriteFileAtomically(p.string(), "nobody's");
    } catch (const Error& e) {
      ::_exit(std::string(e.what()).find("cannot keep the owner 0:0 of " + p.string()) != std::string::npos ? 0 : 2);
    }
    ::_exit(1);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << "1: written, 2: wrong message, 3: setuid failed";
  EXPECT_EQ(ReadWholeFile(p.string()), "root's");
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator{}), 1);
  fs::remove_all(dir);
}

// Catches: a symlinked config (managed elsewhere) replaced by a regular file.
TEST(AtomicFile, WritesThroughASymlink) {
  const fs::path dir = FreshDir("atomic_symlink");
  fs::create_directories(dir / "real");
  const fs::path real = dir / "real" / "vehicle.yaml", link = dir / "vehicle.yaml";
  WriteFileAtomically(real.string(), "old");
  ASSERT_EQ(::chmod(real.c_str(), 0644), 0);
  fs::create_symlink(real, link);
  WriteFileAtomically(link.string(), "new");
  EXPECT_TRUE(fs::is_symlink(link));
  EXPECT_EQ(ReadWholeFile(real.string()), "new");
  EXPECT_EQ(ModeOf(real), 0644u);
  fs::remove_all(dir);
}

TEST(FormatLocation, NamesFileLineColumn) {
  EXPECT_EQ(FormatLocation("a.dbc", 12, 3, "bad"), "a.dbc:12:3: bad");
  EXPECT_EQ(FormatLocation("a.dbc", 0, 0, "bad"), "a.dbc: bad");
}

}  // namespace
}  // namespace ndsid

namespace ndsid {
namespace {

// Catches: a read error swallowed by the stream (a directory read as an empty file, EIO as a
// short file): ReadWholeFile must throw with the path and the reason.
TEST(ReadWholeFile, ReadErrorIsReportedNotAnEmptyFile) {
  const fs::path dir = fs::temp_directory_path() / "ndsid_read_whole_file_dir";
  fs::create_directories(dir);
  try {
    ReadWholeFile(dir.string());
    FAIL() << "a directory read as a file";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("cannot read " + dir.string() + ": Is a directory"), std::string::npos) << e.what();
  }
  fs::remove(dir);
}

// Catches: an input larger than its limit loaded whole into memory.
TEST(ReadWholeFile, LimitIsEnforced) {
  const fs::path p = fs::temp_directory_path() / "ndsid_read_whole_file_limit";
  WriteFileAtomically(p.string(), std::string(100'000, 'x'));
  EXPECT_EQ(ReadWholeFile(p.string()).size(), 100'000u);
  EXPECT_EQ(ReadWholeFile(p.string(), 100'000).size(), 100'000u);
  EXPECT_THROW(ReadWholeFile(p.string(), 99'999), Error);
  fs::remove(p);
}

}  // namespace
}  // namespace ndsid
