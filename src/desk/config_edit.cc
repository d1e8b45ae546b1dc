#include "config_edit.h"

#include <cstdio>
#include <regex>
#include <sstream>

#include "model_report.h"

namespace ndsid::desk {
namespace {

std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> lines;
  std::stringstream ss(text);
  for (std::string l; std::getline(ss, l);) lines.push_back(l);
  return lines;
}

std::string StripComment(const std::string& s) {
  for (size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '#' && (i == 0 || s[i - 1] == ' ' || s[i - 1] == '\t')) return s.substr(0, i);
  }
  return s;
}

std::string Trim(std::string s) {
  s.erase(0, s.find_first_not_of(" \t"));
  s.erase(s.find_last_not_of(" \t\r") + 1);
  return s;
}

size_t Indent(const std::string& l) { return l.find_first_not_of(" \t") == std::string::npos ? l.size() : l.find_first_not_of(" \t"); }

}  // namespace

std::string SetModelEffects(const std::string& yaml_text, const std::vector<std::string>& effects,
                            const std::string& path, std::string* description) {
  return SetModelList(yaml_text, "effects", effects, path, description);
}

std::string SetModelList(const std::string& yaml_text, const std::string& key, const std::vector<std::string>& names,
                         const std::string& path, std::string* description) {
  std::vector<std::string> lines = Lines(yaml_text);
  const auto& strip_comment = StripComment;
  const auto& trim = Trim;
  const std::string list = JoinEffects(names);
  std::string old_list = "[]";
  std::string what;
  static const std::regex kModel(R"(^model\s*:(.*)$)");
  const std::regex kKey("^(\\s+)" + key + "\\s*:(.*)$");
  const std::string entry = "  " + key + ": " + list;
  std::smatch m;
  size_t model_line = lines.size();
  for (size_t i = 0; i < lines.size(); ++i) {
    if (std::regex_match(lines[i], m, kModel)) model_line = i;
  }
  if (model_line == lines.size()) {
    if (!lines.empty() && !trim(lines.back()).empty()) lines.push_back("");
    lines.push_back("model:");
    lines.push_back(entry + "  # written by ndsid diagnose --apply");
    what = "added the model section";
  } else if (std::regex_match(lines[model_line], m, kModel) && !trim(strip_comment(m[1].str())).empty()) {
    if (key != "effects")
      throw ConfigError(path + ": model is written on one line; set model." + key + " by hand (" + list + ")");
    old_list = trim(strip_comment(m[1].str()));
    lines[model_line] = "model:";
    lines.insert(lines.begin() + static_cast<long>(model_line) + 1, entry);
    what = "rewrote the one-line model section at line " + std::to_string(model_line + 1);
  } else {
    size_t end = model_line + 1;
    size_t key_line = lines.size();
    for (; end < lines.size(); ++end) {
      const std::string& l = lines[end];
      const std::string t = trim(l);
      if (!t.empty() && t[0] != '#' && l[0] != ' ' && l[0] != '\t') break;  // next top-level key
      if (key_line == lines.size() && std::regex_match(l, m, kKey)) key_line = end;
    }
    if (key_line == lines.size()) {
      lines.insert(lines.begin() + static_cast<long>(model_line) + 1, entry);
      what = "added model." + key + " at line " + std::to_string(model_line + 2);
    } else {
      std::regex_match(lines[key_line], m, kKey);
      const std::string indent = m[1].str();
      const std::string value = m[2].str();
      const std::string v = trim(strip_comment(value));
      std::string comment = value.substr(strip_comment(value).size());
      if (!v.empty()) {
        old_list = v;
      } else {  // block sequence below: "- name" lines, removed
        std::vector<std::string> old;
        while (key_line + 1 < lines.size()) {
          const std::string t = trim(lines[key_line + 1]);
          if (t.rfind("- ", 0) != 0 && t != "-") break;
          old.push_back(trim(strip_comment(t.substr(1))));
          lines.erase(lines.begin() + static_cast<long>(key_line) + 1);
        }
        old_list = JoinEffects(old);
      }
      const size_t pad = std::max<size_t>(1, 28 - std::min<size_t>(28, indent.size() + key.size() + 2 + list.size()));
      lines[key_line] = indent + key + ": " + list + (comment.empty() ? "" : std::string(pad, ' ') + trim(comment));
      what = "line " + std::to_string(key_line + 1);
    }
  }
  std::string out;
  for (const auto& l : lines) out += l + "\n";
  const config::Config parsed = config::ParseConfig(out, path);
  const std::vector<std::string>& got = key == "effects" ? parsed.model_effects : parsed.model_alternatives;
  if (got != names) {
    throw ConfigError(path + ": editing model." + key + " did not give " + list + " (got " + JoinEffects(got) + ")");
  }
  if (key != "effects" && parsed.model_effects != config::ParseConfig(yaml_text, path).model_effects)
    throw ConfigError(path + ": editing model." + key + " changed model.effects");
  if (description) *description = "model." + key + ": " + old_list + " -> " + list + " (" + what + ")";
  return out;
}

std::string SetRoleLatencies(const std::string& yaml_text, const std::map<config::Role, double>& latency_s,
                             const std::string& path, std::string* description) {
  std::vector<std::string> lines = Lines(yaml_text);
  static const std::regex kSignals(R"(^signals\s*:\s*(#.*)?$)");
  size_t signals = lines.size();
  for (size_t i = 0; i < lines.size(); ++i) {
    if (std::regex_match(lines[i], kSignals)) signals = i;
  }
  if (signals == lines.size()) throw ConfigError(path + ": no block 'signals:' section to edit");
  std::string what;
  for (const auto& [role, value] : latency_s) {
    char num[32];
    std::snprintf(num, sizeof num, "%.3f", value);
    const std::regex key("^(\\s+)" + std::string(config::RoleKey(role)) + "\\s*:(.*)$");
    std::smatch m;
    size_t at = lines.size();
    for (size_t i = signals + 1; i < lines.size(); ++i) {
      const std::string t = Trim(lines[i]);
      if (!t.empty() && t[0] != '#' && Indent(lines[i]) == 0) break;  // next top-level key
      if (std::regex_match(lines[i], m, key)) {
        at = i;
        break;
      }
    }
    if (at == lines.size()) throw ConfigError(path + ": signals." + config::RoleKey(role) + " is not configured");
    std::regex_match(lines[at], m, key);
    const std::string body = StripComment(m[2].str());
    const std::string comment = m[2].str().substr(body.size());
    const std::string flow = Trim(body);
    static const std::regex kLatency(R"(,?\s*latency_s\s*:\s*[-+0-9.eE]+)");
    if (!flow.empty() && flow.front() == '{' && flow.back() == '}') {  // {message: X, ..., latency_s: v}
      std::string inner = std::regex_replace(flow.substr(1, flow.size() - 2), kLatency, "");
      inner = Trim(inner);
      if (!inner.empty() && inner.front() == ',') inner = Trim(inner.substr(1));
      lines[at] = m[1].str() + config::RoleKey(role) + ": {" + inner + (inner.empty() ? "" : ", ") + "latency_s: " + num +
                  "}" + (comment.empty() ? "" : " " + Trim(comment));
    } else if (flow.empty()) {  // block mapping below
      size_t j = at + 1;
      std::string child_indent = m[1].str() + "  ";
      bool replaced = false;
      for (; j < lines.size(); ++j) {
        const std::string t = Trim(lines[j]);
        if (t.empty() || t[0] == '#') continue;
        if (Indent(lines[j]) <= m[1].str().size()) break;
        child_indent = lines[j].substr(0, Indent(lines[j]));
        if (t.rfind("latency_s", 0) == 0) {
          lines[j] = child_indent + "latency_s: " + num;
          replaced = true;
          break;
        }
      }
      if (!replaced) lines.insert(lines.begin() + static_cast<long>(at) + 1, child_indent + "latency_s: " + num);
    } else {
      throw ConfigError(path + ":" + std::to_string(at + 1) + ": signals." + config::RoleKey(role) +
                        " is neither a {...} nor a block mapping");
    }
    what += (what.empty() ? "" : ", ") + std::string(config::RoleKey(role)) + ".latency_s = " + num + " s (line " +
            std::to_string(at + 1) + ")";
  }
  std::string out;
  for (const auto& l : lines) out += l + "\n";
  const config::Config parsed = config::ParseConfig(out, path);
  for (const auto& [role, value] : latency_s) {
    const config::RoleSignal* r = parsed.role(role);
    if (r == nullptr || std::abs(r->latency_s - value) > 6e-4) {
      throw ConfigError(path + ": editing signals." + config::RoleKey(role) + ".latency_s did not give the value");
    }
  }
  if (description) *description = "signals: " + what;
  return out;
}

}  // namespace ndsid::desk
