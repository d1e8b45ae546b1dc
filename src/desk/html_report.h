// One self-contained HTML report (docs/model-workflow.md, "One report"): the page
// scripts/report_html.py builds from what replay, compare and diagnose wrote into their folders
// (plotly from the project venv, its JavaScript embedded: the file opens offline).
#pragma once

#include <string>
#include <vector>

namespace ndsid::desk {

struct HtmlReportInputs {
  std::string replay_dir;    // a replay report folder (estimate.json, eg_history.csv, ...) or empty
  std::string compare_dir;   // a compare folder (summary.json, bins.csv, compare.csv) or empty
  std::string diagnose_dir;  // a diagnose folder (diagnosis.json) or empty
  std::string truth_yaml;    // the simulator's truth.yaml or empty
  std::string title = "ndsid report";
};

// The page's file name in every command's folder.
inline constexpr const char* kHtmlReportName = "ndsid-report.html";

// Writes the page to out_html (atomically, by the script); its output goes to
// <out_html's folder>/ndsid-report.log. False with the reason when the venv's Python or the
// script is missing or the script fails; the caller's other outputs do not depend on it.
// Python: $NDSID_PYTHON or <source>/.venv/bin/python3.
bool WriteHtmlReport(const std::string& out_html, const HtmlReportInputs& inputs, std::string* why_not);

// Writes the page of one command into its output folder `dir` and says so on stdout
// ("page: <path>", or "page not written: <why>"); the command's other outputs stand either way.
void WriteCommandPage(const std::string& dir, const HtmlReportInputs& inputs, const char* indent = "");

// truth.yaml beside the first log, when there is one (simulated drives); else empty.
std::string TruthBeside(const std::vector<std::string>& logs);

}  // namespace ndsid::desk
