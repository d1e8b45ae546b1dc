// `ndsid report`: one self-contained HTML page of a data set (docs/model-workflow.md, "One
// report"): replays the logs (one fit at the end), compares the configured model with the base
// model, diagnoses the missing effects, and assembles the three folders into
// <out>/ndsid-report.html (html_report.h). With --replay/--compare/--diagnose it only assembles
// folders those commands wrote before.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "command_registry.h"
#include "html_report.h"
#include "ndsid/common/error.h"
#include "ndsid/config/config.h"

namespace ndsid::desk {
namespace {
namespace fs = std::filesystem;

struct ReportArgs {
  std::string config = std::string(NDSID_SOURCE_DIR) + "/config/example_vehicle.yaml";
  std::vector<std::string> logs;
  std::string out;
  std::string replay, compare, diagnose;  // assemble these folders instead of running the commands
  std::string truth;
  std::string title;
};

// Another `ndsid` command in process (the registered commands, as the CLI parses them).
int RunSubcommand(const std::vector<std::string>& argv) {
  CLI::App app{"ndsid"};
  app.require_subcommand(1);
  int exit_code = 0;
  for (const auto& cmd : Commands()) cmd.registrar(app, exit_code);
  std::vector<std::string> reversed(argv.rbegin(), argv.rend());  // CLI11 takes them reversed
  app.parse(reversed);
  return exit_code;
}

// The replay's report folder: the one subfolder of `root` with an estimate.json.
std::string ReplayFolder(const fs::path& root) {
  if (fs::exists(root / "estimate.json")) return root.string();
  if (fs::is_directory(root)) {
    for (const auto& e : fs::directory_iterator(root))
      if (e.is_directory() && fs::exists(e.path() / "estimate.json")) return e.path().string();
  }
  return {};
}

int Run(const ReportArgs& a) {
  HtmlReportInputs in;
  in.truth_yaml = a.truth;
  std::string out = a.out;
  const bool assemble = !a.replay.empty() || !a.compare.empty() || !a.diagnose.empty();
  if (assemble) {
    for (const auto* dir : {&a.replay, &a.compare, &a.diagnose})
      if (!dir->empty() && !fs::is_directory(*dir)) throw ConfigError("report: " + *dir + ": no such folder");
    in.replay_dir = a.replay.empty() ? "" : ReplayFolder(a.replay);
    if (!a.replay.empty() && in.replay_dir.empty()) throw ConfigError("report: " + a.replay + ": no estimate.json (not a replay report)");
    in.compare_dir = a.compare;
    in.diagnose_dir = a.diagnose;
    if (out.empty()) out = ".";
  } else {
    const config::Config cfg = config::LoadConfig(a.config);
    const std::vector<std::string> logs = a.logs.empty() ? cfg.source.logs : a.logs;
    if (logs.empty()) throw ConfigError("report: no logs: pass --log or set source.logs in " + a.config);
    if (out.empty()) out = (fs::path(cfg.report_dir) / "report").string();
    fs::create_directories(out);
    std::vector<std::string> with_logs = {"--config", a.config, "--log"};
    with_logs.insert(with_logs.end(), logs.begin(), logs.end());
    auto run = [&](const char* what, std::vector<std::string> argv) {
      std::printf("\n== ndsid %s ==\n", what);
      std::fflush(stdout);
      const int rc = RunSubcommand(argv);
      if (rc != 0) std::printf("ndsid %s exited %d; the report holds what it wrote\n", what, rc);
    };
    std::vector<std::string> replay = {"replay"};
    replay.insert(replay.end(), with_logs.begin(), with_logs.end());
    replay.insert(replay.end(), {"--final-only", "--report", (fs::path(out) / "replay").string()});
    run("replay", replay);
    std::vector<std::string> compare = {"compare"};
    compare.insert(compare.end(), with_logs.begin(), with_logs.end());
    compare.insert(compare.end(), {"--out", (fs::path(out) / "compare").string()});
    run("compare", compare);
    std::vector<std::string> diagnose = {"diagnose"};
    diagnose.insert(diagnose.end(), with_logs.begin(), with_logs.end());
    diagnose.insert(diagnose.end(), {"--out", (fs::path(out) / "diagnose").string()});
    run("diagnose", diagnose);
    in.replay_dir = ReplayFolder(fs::path(out) / "replay");
    in.compare_dir = (fs::path(out) / "compare").string();
    in.diagnose_dir = (fs::path(out) / "diagnose").string();
    if (in.truth_yaml.empty()) in.truth_yaml = TruthBeside(logs);
  }
  in.title = a.title.empty() ? "ndsid report" : a.title;
  const std::string page = (fs::path(out) / kHtmlReportName).string();
  std::string why_not;
  if (!WriteHtmlReport(page, in, &why_not)) {
    std::fprintf(stderr, "ndsid report: the page was not written: %s\n", why_not.c_str());
    return 1;
  }
  std::printf("\nreport: %s\n", page.c_str());
  return 0;
}

void Register(CLI::App& parent, int& exit_code) {
  auto args = std::make_shared<ReportArgs>();
  auto* cmd = parent.add_subcommand(
      "report", "One self-contained HTML report: replay, compare and diagnose a data set, or assemble their folders");
  cmd->add_option("--config", args->config, "Vehicle configuration (YAML)")->capture_default_str();
  cmd->add_option("--log", args->logs, "Log files (default: source.logs of the configuration)");
  cmd->add_option("--out", args->out, "Output folder (default: <report_dir>/report); the page is <out>/ndsid-report.html");
  cmd->add_option("--replay", args->replay, "Assemble only: a replay report folder");
  cmd->add_option("--compare", args->compare, "Assemble only: a compare folder");
  cmd->add_option("--diagnose", args->diagnose, "Assemble only: a diagnose folder");
  cmd->add_option("--truth", args->truth, "The simulator's truth.yaml (default: beside the first log)");
  cmd->add_option("--title", args->title, "The page's title");
  cmd->callback([args, &exit_code] { exit_code = Run(*args); });
}

}  // namespace
}  // namespace ndsid::desk

NDSID_REGISTER_COMMAND(report, ndsid::desk::Register);
