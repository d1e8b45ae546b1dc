#include "replay_document.h"

#include <filesystem>

#include "ndsid/config/truth_file.h"
#include "ndsid/pipeline/estimate_codec.h"

namespace ndsid::desk {

nlohmann::json ReplayDocument(const pipeline::Pipeline& p, const ReplayOutcome& out, const gate::GateCounters& gate) {
  nlohmann::json j;
  j["name"] = out.name;
  j["estimate"] = out.final_estimate ? pipeline::EstimateToJson(*out.final_estimate) : nlohmann::json();
  if (out.truth_eg) j["truth_eg_rad_per_mps2"] = *out.truth_eg;
  j["history"] = nlohmann::json::array();
  for (const auto& e : out.history) j["history"].push_back(pipeline::EstimateToJson(e));
  j["drives"] = nlohmann::json::array();
  for (const auto& d : p.accumulator().drives()) {
    j["drives"].push_back({{"drive", d.drive_id}, {"start_s", d.start_ns * 1e-9}, {"duration_s", (d.end_ns - d.start_ns) * 1e-9},
                           {"distance_km", d.distance_km}, {"gated_s", d.gated_s}, {"used", d.used}});
  }
  j["gate"] = nlohmann::json::object();
  for (int i = 0; i < gate::kNumVerdicts; ++i) j["gate"][gate::VerdictName(static_cast<gate::Verdict>(i))] = gate.by_verdict[i];
  j["gate"]["short_drive"] = p.accumulator().counters().short_drive_samples;
  j["gate"]["short_segment"] = p.accumulator().counters().short_segment_samples;
  j["window"] = {{"segments", p.accumulator().window().size()}, {"hours", p.accumulator().window_hours()},
                 {"gated_hours", p.accumulator().gated_hours()}};
  j["frames"] = out.source.frames;
  j["malformed"] = out.source.malformed;
  j["input_errors"] = out.input_errors;
  j["wall_s"] = out.wall_s;
  return j;
}

std::optional<double> TruthBesideLogs(const std::vector<std::string>& logs) {
  if (logs.empty()) return std::nullopt;
  const std::filesystem::path truth = std::filesystem::path(logs.front()).parent_path() / "truth.yaml";
  std::error_code ec;
  if (!std::filesystem::exists(truth, ec)) return std::nullopt;
  return config::ReadTruthEg(truth.string());
}

}  // namespace ndsid::desk
