#include "html_report.h"

#include "desk_script.h"

#include <cstdio>
#include <filesystem>

namespace ndsid::desk {
namespace fs = std::filesystem;

bool WriteHtmlReport(const std::string& out_html, const HtmlReportInputs& in, std::string* why_not) {
  std::vector<std::string> args = {"--out", out_html, "--title", in.title};
  const std::pair<const char*, const std::string*> optional[] = {
      {"--replay", &in.replay_dir}, {"--compare", &in.compare_dir}, {"--diagnose", &in.diagnose_dir}, {"--truth", &in.truth_yaml}};
  for (const auto& [flag, value] : optional) {
    if (!value->empty()) {
      args.push_back(flag);
      args.push_back(*value);
    }
  }
  const fs::path log = fs::absolute(fs::path(out_html)).parent_path() / "ndsid-report.log";
  return RunDeskScript("report_html.py", args, log, why_not);
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
