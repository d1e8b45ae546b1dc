#include "ndsid/common/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <filesystem>

#include "ndsid/common/error.h"

namespace ndsid {
namespace {

[[noreturn]] void Fail(const std::string& what, const std::string& path, int err) {
  throw Error(what + " " + path + ": " + std::strerror(err));
}

// A new file beside the target, created with mode 0666 so that the kernel applies the
// process umask (or the folder's default ACL) exactly as for any other new file. mkstemp(3)
// would force 0600, which made every report and every edited config private to its writer.
int CreateTemporary(const std::filesystem::path& dir, const std::string& name, std::string* tmp) {
  static std::atomic<unsigned> counter{0};
  for (int attempt = 0; attempt < 100; ++attempt) {
    *tmp = (dir / ("." + name + ".tmp" + std::to_string(::getpid()) + "." + std::to_string(counter++))).string();
    const int fd = ::open(tmp->c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd >= 0 || errno != EEXIST) return fd;
  }
  errno = EEXIST;
  return -1;
}

// The temporary file takes over the replaced file's mode and owner: `diagnose --apply` on a
// root-owned 0644 /etc/ndsid/vehicle.yaml must leave it readable by the service's dynamic
// user. Changing the owner needs privilege; when it is impossible and would change the
// owner, refuse rather than silently hand the file to the editing user.
void KeepModeAndOwner(int fd, const std::string& tmp, const std::string& path, const struct stat& old) {
  struct stat now {};
  if (::fstat(fd, &now) != 0) Fail("cannot stat", tmp, errno);
  if (now.st_uid != old.st_uid || now.st_gid != old.st_gid) {
    if (::fchown(fd, old.st_uid, old.st_gid) != 0) {
      const int err = errno;
      // Only the group may be impossible to keep (not a member of it): then keep the owner
      // and let the group follow the folder's rule, as any new file does.
      if (now.st_uid != old.st_uid) {
        throw Error("cannot keep the owner " + std::to_string(old.st_uid) + ":" + std::to_string(old.st_gid) + " of " +
                    path + " (" + std::strerror(err) + "); edit it as its owner or as root");
      }
    }
  }
  // After the chown, which clears set-id bits.
  if (::fchmod(fd, old.st_mode & 07777) != 0) Fail("cannot set the mode of", tmp, errno);
}

}  // namespace

void WriteFileAtomically(const std::string& path_in, std::string_view contents) {
  // A symlinked target (a config managed elsewhere) is replaced at the link's destination;
  // the link itself stays.
  std::filesystem::path target(path_in);
  std::error_code ec;
  if (std::filesystem::is_symlink(target, ec)) {
    const auto resolved = std::filesystem::weakly_canonical(target, ec);
    if (!ec) target = resolved;
  }
  const std::string path = target.string();
  const std::filesystem::path dir = target.has_parent_path() ? target.parent_path() : ".";
  struct stat old {};
  const bool replacing = ::stat(path.c_str(), &old) == 0 && S_ISREG(old.st_mode);
  std::string tmp;
  const int fd = CreateTemporary(dir, target.filename().string(), &tmp);
  if (fd < 0) Fail("cannot create temporary file for", path, errno);
  try {
    if (replacing) KeepModeAndOwner(fd, tmp, path, old);
    size_t written = 0;
    while (written < contents.size()) {
      const ssize_t n = ::write(fd, contents.data() + written, contents.size() - written);
      if (n < 0) {
        if (errno == EINTR) continue;
        Fail("cannot write", tmp, errno);
      }
      written += static_cast<size_t>(n);
    }
    if (::fsync(fd) != 0) Fail("cannot fsync", tmp, errno);
  } catch (...) {
    ::close(fd);
    ::unlink(tmp.c_str());
    throw;
  }
  ::close(fd);
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    Fail("cannot rename temporary file onto", path, err);
  }
  const int dir_fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY);
  if (dir_fd >= 0) {
    ::fsync(dir_fd);  // make the rename itself durable; failure here loses nothing already written
    ::close(dir_fd);
  }
}

std::string ReadWholeFile(const std::string& path, size_t max_bytes) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) Fail("cannot open", path, errno);
  std::string out;
  char buf[1 << 16];
  for (;;) {
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n == 0) break;
    if (n < 0) {
      if (errno == EINTR) continue;
      const int err = errno;
      ::close(fd);
      Fail("cannot read", path, err);
    }
    if (out.size() + static_cast<size_t>(n) > max_bytes) {
      ::close(fd);
      throw Error("cannot read " + path + ": larger than the limit of " + std::to_string(max_bytes) + " bytes");
    }
    out.append(buf, static_cast<size_t>(n));
  }
  ::close(fd);
  return out;
}

}  // namespace ndsid
