#include "yaml_reader.h"

#include <cmath>

#include "ndsid/common/closest_match.h"

namespace ndsid::config {

YamlReader::YamlReader(const YAML::Node& node, std::string file, std::string path)
    : node_(node), file_(std::move(file)), path_(std::move(path)) {
  if (node_ && !node_.IsMap() && !node_.IsNull()) {
    throw ConfigError(FormatLocation(file_, node_.Mark().line + 1, node_.Mark().column + 1,
                                     (path_.empty() ? std::string("top level") : path_) + ": expected a mapping"));
  }
}

std::string YamlReader::KeyPath(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }

bool YamlReader::Has(const std::string& key) const {
  asked_.insert(key);
  return node_ && node_.IsMap() && node_[key];
}

std::optional<YAML::Node> YamlReader::Get(const std::string& key) const {
  used_.insert(key);
  asked_.insert(key);
  if (!Has(key)) return std::nullopt;
  return node_[key];
}

int YamlReader::Line(const std::string& key) const {
  if (Has(key)) return node_[key].Mark().line + 1;
  return node_ ? node_.Mark().line + 1 : 0;
}

void YamlReader::Fail(const std::string& key, const std::string& message) const {
  throw ConfigError(FormatLocation(file_, Line(key), 0, KeyPath(key) + ": " + message));
}

void YamlReader::FailAt(const YAML::Node& node, const std::string& key, const std::string& message) const {
  throw ConfigError(FormatLocation(file_, node.Mark().line + 1, 0, KeyPath(key) + ": " + message));
}

template <typename T>
T YamlReader::As(const YAML::Node& n, const std::string& key, const char* type_name) const {
  if (!n.IsScalar()) FailAt(n, key, std::string("expected ") + type_name);
  try {
    return n.as<T>();
  } catch (const YAML::Exception&) {
    FailAt(n, key, std::string("expected ") + type_name + ", got '" + n.Scalar() + "'");
  }
}

YamlReader YamlReader::Child(const std::string& key) const {
  const auto n = Get(key);
  if (!n) Fail(key, "missing required section");
  if (!n->IsMap()) FailAt(*n, key, "expected a mapping");
  return YamlReader(*n, file_, KeyPath(key));
}

double YamlReader::Number(const std::string& key) const {
  const auto n = Get(key);
  if (!n) Fail(key, "missing required key");
  const double v = As<double>(*n, key, "a number");
  if (!std::isfinite(v)) FailAt(*n, key, "must be finite");
  return v;
}

double YamlReader::Number(const std::string& key, double fallback) const {
  return Has(key) ? Number(key) : (used_.insert(key), fallback);
}

int YamlReader::Integer(const std::string& key, int fallback) const {
  const auto n = Get(key);
  return n ? As<int>(*n, key, "an integer") : fallback;
}

bool YamlReader::Bool(const std::string& key, bool fallback) const {
  const auto n = Get(key);
  return n ? As<bool>(*n, key, "true or false") : fallback;
}

std::string YamlReader::String(const std::string& key) const {
  const auto n = Get(key);
  if (!n) Fail(key, "missing required key");
  return As<std::string>(*n, key, "a string");
}

std::string YamlReader::String(const std::string& key, const std::string& fallback) const {
  const auto n = Get(key);
  return n ? As<std::string>(*n, key, "a string") : fallback;
}

std::vector<double> YamlReader::Numbers(const std::string& key, const std::vector<double>& fallback) const {
  const auto n = Get(key);
  if (!n) return fallback;
  if (!n->IsSequence()) FailAt(*n, key, "expected a list of numbers");
  std::vector<double> out;
  for (const auto& item : *n) {
    out.push_back(As<double>(item, key, "a number"));
    if (!std::isfinite(out.back())) FailAt(item, key, "must be finite");
  }
  return out;
}

std::vector<std::string> YamlReader::Strings(const std::string& key, const std::vector<std::string>& fallback) const {
  const auto n = Get(key);
  if (!n) return fallback;
  if (n->IsScalar()) return {As<std::string>(*n, key, "a string")};
  if (!n->IsSequence()) FailAt(*n, key, "expected a list of strings");
  std::vector<std::string> out;
  for (const auto& item : *n) out.push_back(As<std::string>(item, key, "a string"));
  return out;
}

std::optional<YAML::Node> YamlReader::Raw(const std::string& key) const { return Get(key); }

void YamlReader::Finish() const {
  if (!node_ || !node_.IsMap()) return;
  for (const auto& kv : node_) {
    if (!kv.first.IsScalar()) {
      throw ConfigError(FormatLocation(file_, kv.first.Mark().line + 1, kv.first.Mark().column + 1,
                                       (path_.empty() ? std::string("top level") : path_) + ": a key must be a plain name"));
    }
    const std::string key = kv.first.as<std::string>();
    if (!used_.count(key)) {
      throw ConfigError(FormatLocation(file_, kv.first.Mark().line + 1, kv.first.Mark().column + 1,
                                       KeyPath(key) + ": unknown key" +
                                           AcceptedValuesHint(key, {asked_.begin(), asked_.end()})));
    }
  }
}

}  // namespace ndsid::config
