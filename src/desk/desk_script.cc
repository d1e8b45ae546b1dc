#include "desk_script.h"

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>

namespace ndsid::desk {
namespace fs = std::filesystem;

fs::path DeskPython() {
  const char* env = std::getenv("NDSID_PYTHON");
  return env ? fs::path(env) : fs::path(NDSID_SOURCE_DIR) / ".venv" / "bin" / "python3";
}

bool RunDeskScript(const std::string& script, const std::vector<std::string>& args, const fs::path& log,
                   std::string* why_not) {
  const fs::path python = DeskPython();
  const fs::path path = fs::path(NDSID_SOURCE_DIR) / "scripts" / script;
  std::error_code ec;
  if (!fs::exists(python, ec)) {
    *why_not = "Python not found at " + python.string() + " (scripts/setup.sh makes the project venv)";
    return false;
  }
  if (!fs::exists(path, ec)) {
    *why_not = "script missing: " + path.string();
    return false;
  }
  std::vector<std::string> all = {python.string(), path.string()};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  const std::string out = log.empty() ? std::string("/dev/null") : log.string();
  const pid_t pid = fork();
  if (pid < 0) {
    *why_not = "fork failed";
    return false;
  }
  if (pid == 0) {  // the child: its output to the log, then the script
    const int fd = open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd >= 0) {
      dup2(fd, STDOUT_FILENO);
      dup2(fd, STDERR_FILENO);
    }
    execv(argv[0], argv.data());
    _exit(127);
  }
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) {
      *why_not = "waitpid failed";
      return false;
    }
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    *why_not = "the script " + script + " failed" + (log.empty() ? std::string() : ", see " + log.string());
    return false;
  }
  return true;
}

}  // namespace ndsid::desk
