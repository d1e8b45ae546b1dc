#include "model_report.h"

#include "desk_script.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>

#include "ndsid/common/atomic_file.h"
#include "ndsid/common/format.h"
#include "ndsid/config/truth_file.h"
#include "ndsid/dbc/dbc_parser.h"
#include "ndsid/identify/model_output.h"
#include "ndsid/model/model_spec.h"

namespace ndsid::desk {
namespace fs = std::filesystem;

std::vector<std::string> SplitNames(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream ss(text);
  for (std::string item; std::getline(ss, item, ',');) {
    item.erase(0, item.find_first_not_of(" \t"));
    item.erase(item.find_last_not_of(" \t") + 1);
    if (!item.empty()) out.push_back(item);
  }
  return out;
}

std::vector<std::string> ParseEffectList(const std::string& text, const model::EffectLibrary& library) {
  if (text.empty() || text == "none") return {};
  std::vector<std::string> out = SplitNames(text);
  model::ModelSpec::FromNames(out, library);  // throws ConfigError naming an unknown effect
  return out;
}

std::string JoinEffects(const std::vector<std::string>& effects) {
  std::string s = "[";
  for (size_t i = 0; i < effects.size(); ++i) s += (i ? ", " : "") + effects[i];
  return s + "]";
}

std::unique_ptr<ReplayedData> ReplayForModelWork(const std::string& config_path, const std::vector<std::string>& logs,
                                                 const std::vector<std::string>& pipeline_effects) {
  auto d = std::make_unique<ReplayedData>();
  d->config = config::LoadConfig(config_path);
  model::ModelSpec::FromNames(pipeline_effects, model::EffectLibrary(d->config.model_formulas));  // before the replay
  d->config.model_effects = pipeline_effects;
  d->config.model_alternatives.clear();  // the desk fits the models it compares itself
  const std::vector<std::string> use = logs.empty() ? d->config.source.logs : logs;
  if (use.empty()) throw ConfigError("no log to replay: give --log FILE or source.logs in " + config_path);
  for (const std::string& p : use) {
    if (!fs::is_regular_file(p)) throw ConfigError("log file not found: " + p);
  }
  d->db = dbc::ParseDbcFile(d->config.dbc);
  d->pipeline = std::make_unique<pipeline::Pipeline>(d->config, d->db);
  ReplayOptions opt;
  opt.logs = use;
  opt.identify_periodically = false;
  d->outcome = RunReplay(*d->pipeline, d->config, opt);
  d->outcome.name = fs::path(use.front()).parent_path().filename().string();
  d->window = d->pipeline->Snapshot();
  if (d->window.training.empty()) throw Error("no gated segment long enough for the fit in " + JoinEffects(use));
  const fs::path truth = fs::path(use.front()).parent_path() / "truth.yaml";
  if (fs::exists(truth)) d->truth_noise_mps2 = config::ReadTruthNumber(truth.string(), "noise.lat_accel_mps2");
  return d;
}

std::vector<int64_t> ParseDriveList(const std::string& text) {
  std::vector<int64_t> out;
  if (text.empty() || text == "auto") return out;
  std::stringstream ss(text);
  for (std::string item; std::getline(ss, item, ',');) {
    try {
      size_t used = 0;
      out.push_back(std::stoll(item, &used));
      if (used != item.size()) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      throw ConfigError("--hold-out: '" + item + "' is not a drive number (see the drive table of `ndsid replay`)");
    }
  }
  return out;
}

void HoldOutDrives(ReplayedData& data, const std::vector<int64_t>& drives) {
  if (drives.empty()) return;
  std::vector<int64_t> present;
  for (const auto& seg : data.window.keep_alive)
    if (std::find(present.begin(), present.end(), seg->drive_id) == present.end()) present.push_back(seg->drive_id);
  for (int64_t d : drives) {
    if (std::find(present.begin(), present.end(), d) == present.end()) {
      std::string list;
      for (int64_t p : present) list += (list.empty() ? "" : ", ") + std::to_string(p);
      throw ConfigError("--hold-out: drive " + std::to_string(d) + " is not in the window (drives: " + list + ")");
    }
  }
  data.window.training.clear();
  data.window.validation.clear();
  for (const auto& seg : data.window.keep_alive) {
    const bool held = std::find(drives.begin(), drives.end(), seg->drive_id) != drives.end();
    (held ? data.window.validation : data.window.training).push_back(seg.get());
  }
  if (data.window.training.empty()) throw ConfigError("--hold-out: every drive held out, none left to train on");
  data.custom_split = true;
}

std::optional<identify::IdentificationResult> ReplayedFit(const ReplayedData& data, const std::vector<std::string>& effects) {
  const auto& last = data.pipeline->last_estimate();
  if (data.custom_split || effects != data.config.model_effects || !last || !last->fit.valid) return std::nullopt;
  return last->fit;
}

FittedModel FitModel(const ReplayedData& data, const std::string& label, const std::vector<std::string>& effects) {
  FittedModel m{label, effects, {}};
  if (auto fit = ReplayedFit(data, effects)) {
    m.fit = std::move(*fit);  // the pipeline just fitted this very model on this window
    return m;
  }
  identify::Identifier id(data.config.identification, data.config.vehicle.wheelbase_m,
                          model::ModelSpec::FromNames(effects, data.pipeline->library()));
  id.set_standstill(data.window.standstill);
  std::optional<model::Params<double>> warm;
  const auto& ss = data.window.steady_state;
  if (ss.valid) warm = id.WarmStart(ss.steer_ratio, ss.eg_rad_per_mps2);
  m.fit = id.Identify(data.window.training, data.window.validation, warm);
  return m;
}

const char* VerdictText(BinVerdict v) {
  switch (v) {
    case BinVerdict::kOk: return "ok";
    case BinVerdict::kTooFew: return "too few";
    case BinVerdict::kFailBias: return "FAIL bias";
    case BinVerdict::kFailRmse: return "FAIL rmse";
  }
  return "?";
}

BinStats ComputeBin(const std::vector<double>& e, const std::vector<int>& cluster, double noise_floor,
                    double overall_rmse) {
  BinStats b;
  b.n = e.size();
  if (b.n == 0) return b;
  double sum = 0, sq = 0;
  for (double v : e) sum += v, sq += v * v;
  b.bias = sum / static_cast<double>(b.n);
  b.rmse = std::sqrt(sq / static_cast<double>(b.n));
  std::map<int, double> by_cluster;  // sum of (e - bias) per chunk
  for (size_t i = 0; i < e.size(); ++i) by_cluster[cluster[i]] += e[i] - b.bias;
  b.clusters = static_cast<int>(by_cluster.size());
  double meat = 0;
  for (const auto& [c, s] : by_cluster) meat += s * s;
  const double g = b.clusters;
  b.se = g > 1 ? std::sqrt(meat * g / (g - 1.0)) / static_cast<double>(b.n) : INFINITY;
  if (b.n < kMinBinSamples) {
    b.verdict = BinVerdict::kTooFew;
  } else if (b.clusters >= 3 && std::abs(b.bias) > kBiasZ * b.se && std::abs(b.bias) > 0.5 * noise_floor) {
    b.verdict = BinVerdict::kFailBias;
  } else if (b.rmse > kRmseFactor * overall_rmse) {
    b.verdict = BinVerdict::kFailRmse;
  } else {
    b.verdict = BinVerdict::kOk;
  }
  return b;
}

namespace {

struct BinDef {
  std::string group, label;
  std::function<bool(const SampleRow&)> in;
};

std::vector<BinDef> BinDefinitions(const std::vector<SampleRow>& rows) {
  std::vector<BinDef> defs;
  auto band = [](double lo, double hi) {
    char b[48];
    if (std::isinf(hi)) std::snprintf(b, sizeof b, ">%g", lo);
    else std::snprintf(b, sizeof b, "%g-%g", lo, hi);
    return std::string(b);
  };
  for (double lo : {0.0, 1.0, 2.0, 3.0}) {
    defs.push_back({"|a_y| [m/s^2]", band(lo, lo + 1), [lo](const SampleRow& r) {
                      return std::abs(r.ay_mps2) >= lo && std::abs(r.ay_mps2) < lo + 1;
                    }});
  }
  const double v_edges[] = {5, 10, 20, 30, INFINITY};
  for (int i = 0; i < 4; ++i) {
    const double lo = v_edges[i], hi = v_edges[i + 1];
    defs.push_back({"v [m/s]", band(lo, hi), [lo, hi](const SampleRow& r) { return r.speed_mps >= lo && r.speed_mps < hi; }});
  }
  for (int i = 0; i < 4; ++i) {
    const double lo = v_edges[i], hi = v_edges[i + 1];
    defs.push_back({"straight |a_y|<0.5, v [m/s]", band(lo, hi), [lo, hi](const SampleRow& r) {
                      return std::abs(r.ay_mps2) < 0.5 && r.speed_mps >= lo && r.speed_mps < hi;
                    }});
  }
  const double sr_edges[] = {0, 0.05, 0.2, 0.5, INFINITY};
  for (int i = 0; i < 4; ++i) {
    const double lo = sr_edges[i], hi = sr_edges[i + 1];
    defs.push_back({"|steering rate| [rad/s]", band(lo, hi), [lo, hi](const SampleRow& r) {
                      return std::abs(r.steer_rate_radps) >= lo && std::abs(r.steer_rate_radps) < hi;
                    }});
  }
  defs.push_back({"a_x [m/s^2]", "braking <-0.5", [](const SampleRow& r) { return r.ax_mps2 < -0.5; }});
  defs.push_back({"a_x [m/s^2]", "coasting", [](const SampleRow& r) { return std::abs(r.ax_mps2) <= 0.5; }});
  defs.push_back({"a_x [m/s^2]", "driving >0.5", [](const SampleRow& r) { return r.ax_mps2 > 0.5; }});
  defs.push_back({"set", "training", [](const SampleRow& r) { return !r.validation; }});
  defs.push_back({"set", "validation", [](const SampleRow& r) { return r.validation; }});
  std::vector<int64_t> drives;
  for (const auto& r : rows)
    if (std::find(drives.begin(), drives.end(), r.drive) == drives.end()) drives.push_back(r.drive);
  std::sort(drives.begin(), drives.end());
  for (int64_t d : drives) {
    defs.push_back({"drive", std::to_string(d), [d](const SampleRow& r) { return r.drive == d; }});
  }
  return defs;
}

// The residual of one output: a_y [m/s^2], or the yaw rate [deg/s].
double Measured(const SampleRow& r, bool yaw) { return yaw ? r.yaw_rate_radps * 180.0 / M_PI : r.ay_mps2; }
double Residual(const SampleRow& r, size_t model, bool yaw) {
  return yaw ? (r.yaw_rate_radps - r.yaw_model[model]) * 180.0 / M_PI : r.ay_mps2 - r.ay_model[model];
}

FitFigures Figures(const std::vector<SampleRow>& rows, size_t model, bool validation, bool yaw = false) {
  FitFigures f;
  double sy = 0, se = 0, see = 0, syy = 0;
  for (const auto& r : rows) {
    if (!r.scored || r.validation != validation) continue;
    const double y = Measured(r, yaw), e = Residual(r, model, yaw);
    ++f.n, sy += y, syy += y * y, se += e, see += e * e;
  }
  if (f.n == 0) return f;
  const double n = static_cast<double>(f.n);
  f.rmse = std::sqrt(see / n);
  f.bias = se / n;
  const double dev = std::sqrt(std::max(syy - sy * sy / n, 1e-300));
  f.nrmse_fit_pct = 100.0 * (1.0 - std::sqrt(see) / dev);
  return f;
}

}  // namespace

Comparison Compare(const ReplayedData& data, std::vector<FittedModel> models, std::optional<double> noise_floor) {
  Comparison c;
  c.models = std::move(models);
  identify::SegmentList all = data.window.training;
  all.insert(all.end(), data.window.validation.begin(), data.window.validation.end());
  const size_t n_train_segments = data.window.training.size();
  std::vector<std::vector<identify::ChunkOutput>> outs;
  for (const FittedModel& m : c.models) {
    if (!m.fit.valid) throw Error("the " + m.label + " model " + JoinEffects(m.effects) + " has no valid fit: " + m.fit.reason);
    identify::Identifier id(data.config.identification, data.config.vehicle.wheelbase_m,
                            model::ModelSpec::FromNames(m.effects, data.pipeline->library()));
    id.set_drive_values(m.fit.drive_values);  // per-drive parameters: each drive at its fitted values
    outs.push_back(identify::SimulateChunks(id, m.fit.ValuesFor(id.spec()), all));
  }
  const size_t nm = c.models.size();
  for (size_t ci = 0; ci < outs[0].size(); ++ci) {
    const identify::ChunkOutput& o = outs[0][ci];
    const stats::Segment& seg = *o.segment;
    for (size_t k = 0; k < o.n; ++k) {
      const size_t i = o.first + k;
      const auto& s = seg.samples[i];
      const size_t a = i > 0 ? i - 1 : i, b = i + 1 < seg.samples.size() ? i + 1 : i;
      SampleRow r;
      r.t_s = seg.t0_ns * 1e-9 + static_cast<double>(i) * seg.dt_s;
      r.drive = seg.drive_id;
      r.segment = static_cast<int>(o.segment_index);
      r.chunk = static_cast<int>(ci);
      r.k = static_cast<int>(k);
      r.scored = k >= o.burn_in;
      r.validation = o.segment_index >= n_train_segments;
      r.steer_rad = s.steer_rad;
      r.steer_rate_radps = b > a ? (seg.samples[b].steer_rad - seg.samples[a].steer_rad) / ((b - a) * seg.dt_s) : 0.0;
      r.speed_mps = s.speed_mps;
      r.ax_mps2 = seg.has_long_accel ? s.long_accel_mps2 : NAN;
      r.ay_mps2 = s.lat_accel_mps2;
      r.yaw_rate_radps = seg.has_yaw_rate ? s.yaw_rate_radps : NAN;
      for (size_t m = 0; m < nm; ++m) {
        r.ay_model.push_back(outs[m][ci].a_y_model_mps2[k]);
        r.yaw_model.push_back(outs[m][ci].yaw_rate_model_radps[k]);
      }
      c.rows.push_back(std::move(r));
    }
  }
  c.has_yaw_rate = !c.rows.empty();
  for (const SampleRow& r : c.rows) {
    if (!r.scored) continue;
    bool finite = std::isfinite(r.yaw_rate_radps);
    for (double y : r.yaw_model) finite = finite && std::isfinite(y);
    if (!finite) {
      c.has_yaw_rate = false;
      break;
    }
  }
  c.yaw_rate_fitted = data.config.identification.yaw_rate_output;
  // White part of the residual (differencing removes what is smooth at 50 Hz) and the RMSE over
  // every scored sample, of one output.
  auto white_and_rmse = [&](size_t m, bool yaw, double& white, double& rmse) {
    double sd = 0, sdd = 0, see = 0;
    size_t nd = 0, ne = 0;
    for (size_t i = 0; i < c.rows.size(); ++i) {
      const SampleRow& r = c.rows[i];
      if (!r.scored) continue;
      const double e = Residual(r, m, yaw);
      see += e * e, ++ne;
      if (i == 0 || !c.rows[i - 1].scored || c.rows[i - 1].chunk != r.chunk) continue;
      const double d = e - Residual(c.rows[i - 1], m, yaw);
      sd += d, sdd += d * d, ++nd;
    }
    const double var = nd > 1 ? (sdd - sd * sd / nd) / (nd - 1.0) : 0.0;
    white = std::sqrt(std::max(0.0, var) / 2.0);
    rmse = ne ? std::sqrt(see / ne) : 0.0;
  };
  // A role slower than the fit reads its floor low by this much (identify::SlowOutputFloorFactor).
  const double slow_a = identify::SlowOutputFloorFactor(data.window.a_y_interval_s, data.config.identification.rate_hz);
  const double slow_r = identify::SlowOutputFloorFactor(data.window.yaw_rate_interval_s, data.config.identification.rate_hz);
  for (size_t m = 0; m < nm; ++m) {
    c.train.push_back(Figures(c.rows, m, false));
    c.validation.push_back(Figures(c.rows, m, true));
    double white = 0, rmse = 0;
    white_and_rmse(m, false, white, rmse);
    c.white_noise.push_back(white * slow_a);
    c.overall_rmse.push_back(rmse);
    if (c.has_yaw_rate) {
      c.yaw_train.push_back(Figures(c.rows, m, false, true));
      c.yaw_validation.push_back(Figures(c.rows, m, true, true));
      white_and_rmse(m, true, white, rmse);
      c.yaw_white_noise.push_back(white * slow_r);
      c.yaw_overall_rmse.push_back(rmse);
    }
  }
  if (noise_floor) {
    c.noise_floor = *noise_floor;
    c.noise_floor_source = "--noise-floor";
  } else {
    c.noise_floor = *std::min_element(c.white_noise.begin(), c.white_noise.end());
    c.noise_floor_source = "white part of the residual, sqrt(var(diff e)/2), smallest over the models";
    if (slow_a > 1) c.noise_floor_source += Fmt(", x %.2f for a_y's values %.2f fit samples apart", slow_a, slow_a);
  }
  if (c.has_yaw_rate) c.yaw_noise_floor = *std::min_element(c.yaw_white_noise.begin(), c.yaw_white_noise.end());
  auto bins = [&](bool yaw) {
    std::vector<Bin> out;
    for (const BinDef& def : BinDefinitions(c.rows)) {
      Bin bin{def.group, def.label, {}};
      for (size_t m = 0; m < nm; ++m) {
        std::vector<double> e;
        std::vector<int> cl;
        for (const SampleRow& r : c.rows) {
          if (!r.scored || !def.in(r)) continue;
          e.push_back(Residual(r, m, yaw));
          cl.push_back(r.chunk);
        }
        bin.per_model.push_back(yaw ? ComputeBin(e, cl, c.yaw_noise_floor, c.yaw_overall_rmse[m])
                                    : ComputeBin(e, cl, c.noise_floor, c.overall_rmse[m]));
      }
      out.push_back(std::move(bin));
    }
    return out;
  };
  c.bins = bins(false);
  if (c.has_yaw_rate) c.yaw_bins = bins(true);
  c.gains = ComputeGainView(c.rows, nm, false);
  if (c.has_yaw_rate) c.yaw_gains = ComputeGainView(c.rows, nm, true);
  return c;
}

void PrintComparison(const Comparison& c) {
  for (size_t m = 0; m < c.models.size(); ++m) {
    const auto& f = c.models[m].fit;
    char held_out[32] = "n/a";  // rounded like the other figures (it used to be cut to 6 characters)
    if (c.validation[m].n) std::snprintf(held_out, sizeof held_out, "%.4f", c.validation[m].rmse);
    std::printf("%-8s %-40s EG = %.3f ± %.3f deg/g   RMSE train %.4f, held-out %s m/s^2   fit %.1f %% / %.1f %%\n",
                c.models[m].label.c_str(), f.model.c_str(), f.eg_deg_per_g, f.eg_se_deg_per_g, c.train[m].rmse,
                held_out,
                c.train[m].nrmse_fit_pct, c.validation[m].nrmse_fit_pct);
    for (const auto& p : f.effect_params) {
      std::printf("         %s = %.5g ± %.2g %s\n", p.name.c_str(), p.value, p.se, p.unit.c_str());
    }
    for (const auto& v : f.drive_values) {
      std::printf("         %s drive %lld = %.5g ± %.2g%s\n", v.param.c_str(), static_cast<long long>(v.drive_id), v.value, v.se,
                  v.reference ? " (reference: the parameters and EG describe this drive)" : v.validation ? " (held out)" : "");
    }
  }
  std::printf("noise floor %.4f m/s^2 (%s)\n", c.noise_floor, c.noise_floor_source.c_str());
  if (c.has_yaw_rate) {
    for (size_t m = 0; m < c.models.size(); ++m) {
      char held_out[32] = "n/a";
      if (c.yaw_validation[m].n) std::snprintf(held_out, sizeof held_out, "%.4f", c.yaw_validation[m].rmse);
      std::printf("yaw rate %-8s RMSE train %.4f, held-out %s deg/s (%s)\n", c.models[m].label.c_str(), c.yaw_train[m].rmse,
                  held_out, c.yaw_rate_fitted ? "fitted" : "not fitted: predicted by the a_y fit");
    }
    std::printf("yaw-rate noise floor %.4f deg/s\n", c.yaw_noise_floor);
  }
  auto table = [&](const std::vector<Bin>& bins, const char* title) {
    std::printf("\n%s, bias ± clustered SE (chunks), RMSE\n", title);
    std::printf("%-28s %-13s", "bin", "");
    for (const auto& m : c.models) std::printf(" | %-8s %7s %6s %6s %-9s", m.label.c_str(), "bias", "se", "rmse", "verdict");
    std::printf("\n");
    std::string group;
    for (const Bin& b : bins) {
      std::printf("%-28s %-13s", b.group == group ? "" : b.group.c_str(), b.label.c_str());
      group = b.group;
      for (const BinStats& s : b.per_model) {
        std::printf(" | n=%-6zu %+7.3f %6.3f %6.3f %-9s", s.n, s.bias, std::isfinite(s.se) ? s.se : 0.0, s.rmse,
                    VerdictText(s.verdict));
      }
      std::printf("\n");
    }
  };
  table(c.bins, "where it fails: residual e = a_y,meas - a_y,model [m/s^2]");
  if (c.has_yaw_rate) table(c.yaw_bins, "where it fails, yaw rate: residual e_r = r_meas - r_model [deg/s]");
  PrintGainView(c.gains, c.models, "a_y");
  if (c.has_yaw_rate) PrintGainView(c.yaw_gains, c.models, "yaw rate");
}

std::string HtmlEscape(const std::string& s) {
  std::string o;
  for (char ch : s) {
    switch (ch) {
      case '<': o += "&lt;"; break;
      case '>': o += "&gt;"; break;
      case '&': o += "&amp;"; break;
      case '"': o += "&quot;"; break;
      default: o += ch;
    }
  }
  return o;
}

bool RunPlotScript(const std::string& mode, const std::string& dir, std::string* why_not) {
  return RunDeskScript("model_report_plots.py", {mode, dir}, fs::path(dir) / "plots.log", why_not);
}

}  // namespace ndsid::desk
