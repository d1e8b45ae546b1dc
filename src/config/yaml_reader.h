// A strict reader over yaml-cpp nodes: every key read is remembered, so Finish() can reject
// unknown keys; every error names the file, the line and the key path.
#pragma once

#include <yaml-cpp/yaml.h>

#include <optional>
#include <set>
#include <string>
#include <vector>

#include "ndsid/common/error.h"

namespace ndsid::config {

class YamlReader {
 public:
  YamlReader(const YAML::Node& node, std::string file, std::string path);

  bool Has(const std::string& key) const;
  YamlReader Child(const std::string& key) const;  // required mapping
  double Number(const std::string& key) const;
  double Number(const std::string& key, double fallback) const;
  int Integer(const std::string& key, int fallback) const;
  bool Bool(const std::string& key, bool fallback) const;
  std::string String(const std::string& key) const;
  std::string String(const std::string& key, const std::string& fallback) const;
  std::vector<double> Numbers(const std::string& key, const std::vector<double>& fallback) const;
  std::vector<std::string> Strings(const std::string& key, const std::vector<std::string>& fallback) const;
  // A key's raw node (marks it used), for sequences of mappings.
  std::optional<YAML::Node> Raw(const std::string& key) const;

  // Throws for every key of this mapping that was never read.
  void Finish() const;

  [[noreturn]] void Fail(const std::string& key, const std::string& message) const;
  [[noreturn]] void FailAt(const YAML::Node& node, const std::string& key, const std::string& message) const;
  int Line(const std::string& key) const;
  const std::string& file() const { return file_; }
  const std::string& path() const { return path_; }
  const YAML::Node& node() const { return node_; }

 private:
  std::string KeyPath(const std::string& key) const;
  std::optional<YAML::Node> Get(const std::string& key) const;
  template <typename T>
  T As(const YAML::Node& n, const std::string& key, const char* type_name) const;

  YAML::Node node_;
  std::string file_;
  std::string path_;
  mutable std::set<std::string> used_;
  mutable std::set<std::string> asked_;  // every key this reader knows (read or tested): the accepted ones
};

}  // namespace ndsid::config
