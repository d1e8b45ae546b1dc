// The desk's Python helper scripts (scripts/*.py: plots, the HTML page) run in the project venv,
// as a child process without a shell: any path (quotes, spaces) is passed through unchanged.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace ndsid::desk {

// The Python the desk's scripts run with: $NDSID_PYTHON, else <source>/.venv/bin/python3.
std::filesystem::path DeskPython();

// Runs <DeskPython()> <source>/scripts/<script> <args...> with stdout and stderr written to
// `log` (empty: discarded) and waits for it. True when it exited 0; else false with the reason
// (Python or the script missing, fork failed, the script failed: see the log).
bool RunDeskScript(const std::string& script, const std::vector<std::string>& args, const std::filesystem::path& log,
                   std::string* why_not);

}  // namespace ndsid::desk
