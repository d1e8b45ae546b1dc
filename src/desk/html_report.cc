#include "html_report.h"

#include "model_report.h"

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>

namespace ndsid::desk {
namespace fs = std::filesystem;

bool WriteHtmlReport(const std::string& out_html, const HtmlReportInputs& in, std::string* why_not) {
  const fs::path script = fs::path(NDSID_SOURCE_DIR) / "scripts" / "report_html.py";
  const fs::path python = DeskPython();
  if (!fs::exists(python)) {
    *why_not = "Python not found at " + python.string() + " (run scripts/setup.sh for the venv with plotly)";
    return false;
  }
  if (!fs::exists(script)) {
    *why_not = "report script missing: " + script.string();
    return false;
  }
  std::vector<std::string> args = {python.string(), script.string(), "--out", out_html, "--title", in.title};
  const std::pair<const char*, const std::string*> optional[] = {
      {"--replay", &in.replay_dir}, {"--compare", &in.compare_dir}, {"--diagnose", &in.diagnose_dir}, {"--truth", &in.truth_yaml}};
  for (const auto& [flag, value] : optional) {
    if (!value->empty()) {
      args.push_back(flag);
      args.push_back(*value);
    }
  }
  const fs::path log = fs::absolute(fs::path(out_html)).parent_path() / "ndsid-report.log";
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  const pid_t pid = fork();
  if (pid < 0) {
    *why_not = "fork failed";
    return false;
  }
  if (pid == 0) {  // the child: its output to the log, then the script (no shell: any path is safe)
    const int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd >= 0) {
      dup2(fd, STDOUT_FILENO);
      dup2(fd, STDERR_FILENO);
    }
    execv(argv[0], argv.data());
    _exit(127);
  }
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    *why_not = "the report script failed, see " + log.string();
    return false;
  }
  return true;
}

void WriteCommandPage(const std::string& dir, const HtmlReportInputs& inputs, const char* indent) {
  std::string why;
  const std::string path = (fs::path(dir) / kHtmlReportName).string();
  if (WriteHtmlReport(path, inputs, &why)) std::printf("%spage: %s\n", indent, path.c_str());
  else std::printf("%spage not written: %s\n", indent, why.c_str());
}

std::string TruthBeside(const std::vector<std::string>& logs) {
  if (logs.empty()) return {};
  std::error_code ec;
  const fs::path truth = fs::path(logs.front()).parent_path() / "truth.yaml";
  return fs::exists(truth, ec) ? truth.string() : std::string();
}

}  // namespace ndsid::desk
