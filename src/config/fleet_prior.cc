// identification.prior_from: a fleet prior (docs/fleet.md, "The fleet prior"), named either as
// a group's fleet_prior.yaml or as the fleet table (fleet.parquet) with identification.prior_group.
// The group priors are derived from the table by `ndsid fleet` (Python) and written beside it;
// each records the table's size and CRC-32, so a table changed after its priors were written is
// a located error here instead of a prior from other vehicles.
#include <yaml-cpp/yaml.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>

#include "config_sections.h"
#include "ndsid/common/atomic_file.h"

namespace ndsid::config {
namespace {

constexpr size_t kMaxPriorBytes = 1 << 20;
constexpr size_t kMaxTableBytes = size_t{1} << 30;

// The command that writes a group's prior from the table as it is now.
std::string WriteAgain(const IdentificationConfig& ic) {
  return "python -m ndsid fleet prior --fleet " + ic.prior_from + " --group " + ic.prior_group;
}

// The group's folder name under OUT/groups/, as `ndsid fleet` writes it.
std::string GroupFolder(const std::string& group) {
  std::string out = group;
  for (char& ch : out) {
    const bool keep = (ch >= 'A' && ch <= 'Z') || (ch >= 'a' && ch <= 'z') || (ch >= '0' && ch <= '9') || ch == '.' ||
                      ch == '_' || ch == '-';
    if (!keep) ch = '_';
  }
  return out.empty() ? "_" : out;
}

std::string Crc32Hex(const std::string& bytes) {
  uLong crc = crc32(0L, Z_NULL, 0);
  for (size_t at = 0; at < bytes.size();) {
    const uInt n = static_cast<uInt>(std::min<size_t>(bytes.size() - at, 1u << 30));
    crc = crc32(crc, reinterpret_cast<const Bytef*>(bytes.data() + at), n);
    at += n;
  }
  char buf[16];
  std::snprintf(buf, sizeof buf, "%08lx", static_cast<unsigned long>(crc));
  return buf;
}

// The prior's `source` against the table it claims to come from.
void CheckSource(const YAML::Node& root, const IdentificationConfig& ic,
                 const std::function<void(const std::string&)>& fail) {
  const std::string& table = ic.prior_from;
  const std::string refresh = "; write the group's prior again: " + WriteAgain(ic);
  const YAML::Node src = root["source"];
  if (!src || !src.IsMap() || !src["crc32"] || !src["bytes"]) fail("records no source table" + refresh);
  std::string bytes;
  try {
    bytes = ReadWholeFile(table, kMaxTableBytes);
  } catch (const Error& e) {
    fail(e.what());
  }
  std::string crc;
  long long size = -1;
  try {
    crc = src["crc32"].as<std::string>();
    size = src["bytes"].as<long long>();
  } catch (const YAML::Exception&) {
    fail("source needs a text 'crc32' and a number 'bytes'" + refresh);
  }
  if (size != static_cast<long long>(bytes.size()) || crc != Crc32Hex(bytes)) {
    fail("was derived from another version of " + table + " (CRC-32 " + crc + ", " + std::to_string(size) +
         " bytes; the table now " + Crc32Hex(bytes) + ", " + std::to_string(bytes.size()) + " bytes)" + refresh);
  }
}

}  // namespace

bool NamesFleetTable(const std::string& prior_from) {
  const std::string tail = ".parquet";
  return prior_from.size() > tail.size() && prior_from.compare(prior_from.size() - tail.size(), tail.size(), tail) == 0;
}

void ApplyFleetPrior(const std::string& config_path, const VehicleConfig& vehicle, IdentificationConfig& ic) {
  const bool from_table = NamesFleetTable(ic.prior_from);
  const std::string file =
      from_table ? (std::filesystem::path(ic.prior_from).parent_path() / "groups" / GroupFolder(ic.prior_group) /
                    "fleet_prior.yaml").string()
                 : ic.prior_from;
  const std::string where = from_table ? ic.prior_from + ", group " + ic.prior_group + ": " + file : file;
  auto fail = [&](const std::string& why) {
    throw ConfigError(config_path + ": identification.prior_from: " + where + ": " + why);
  };
  if (from_table && !std::filesystem::exists(file)) {
    fail("no prior for this group beside the table (ndsid fleet writes one per group with at least 3 valid "
         "vehicles; check the group's name, or write it: " + WriteAgain(ic) + ")");
  }
  YAML::Node root;
  try {
    root = YAML::Load(ReadWholeFile(file, kMaxPriorBytes));
  } catch (const YAML::Exception& e) {
    fail("YAML syntax at line " + std::to_string(e.mark.line + 1) + ": " + e.msg);
  } catch (const Error& e) {
    fail(e.what());
  }
  if (!root.IsMap() || !root["parameters"] || !root["parameters"].IsMap()) fail("not a fleet prior (needs 'parameters')");
  if (!ic.prior_group.empty() && root["group"] && root["group"].IsScalar() &&
      root["group"].Scalar() != ic.prior_group) {
    fail("is the prior of group '" + root["group"].Scalar() + "', not of '" + ic.prior_group + "'");
  }
  if (from_table) CheckSource(root, ic, fail);
  // The fleet's keys (docs/fleet.md): per kilogram of the vehicle's mass for Jz, cv, ch.
  struct Key {
    const char* param;
    const char* fleet;
    bool per_kg;
  };
  static const Key kKeys[] = {{"Jz", "Jz_per_m", true}, {"cv", "cv_per_m", true}, {"ch", "ch_per_m", true},
                              {"lv", "lv", false}, {"is", "is", false}};
  auto configured = [&](const std::string& name) {
    return std::any_of(ic.priors.begin(), ic.priors.end(), [&](const ParameterPrior& q) { return q.name == name; });
  };
  // An entry's mean and sd (`what` names it in the error).
  auto mean_sd = [&](const YAML::Node& entry, const std::string& what) {
    try {
      return std::pair{entry["mean"].as<double>(), entry["sd"].as<double>()};
    } catch (const YAML::Exception&) {
      fail(what + " needs numbers 'mean' and 'sd'");
    }
    return std::pair{0.0, 0.0};  // not reached: fail throws
  };
  for (const Key& k : kKeys) {
    const YAML::Node p = root["parameters"][k.fleet];
    if (!p || configured(k.param)) continue;
    const auto [mean, sd] = mean_sd(p, std::string("parameters.") + k.fleet);
    const double scale = k.per_kg ? vehicle.mass_kg : 1.0;
    if (!std::isfinite(mean) || !std::isfinite(sd) || !(mean > 0) || !(sd > 0) || mean * scale > kMaxPhysical) {
      fail(std::string("parameters.") + k.fleet + ": a prior needs a positive finite mean and sd > 0");
    }
    ic.priors.push_back({k.param, mean * scale, std::max(sd * scale, 1e-9 * mean * scale), where});
  }
  // The group's EG: its vehicles' parameter errors are correlated (their EGs agree far better than
  // their cv, ch and lv), which independent priors on the parameters cannot say.
  const YAML::Node eg = root[kEgPriorName];
  if (eg && !configured(kEgPriorName)) {
    const auto [mean, sd] = mean_sd(eg, kEgPriorName);
    if (!std::isfinite(mean) || !std::isfinite(sd) || !(sd > 0) || std::abs(mean) > kMaxPhysical) {
      fail(std::string(kEgPriorName) + ": a prior needs a finite mean and sd > 0");
    }
    ic.priors.push_back({kEgPriorName, mean, sd, where});
  }
}

}  // namespace ndsid::config
