// The per-drive parameters (model::EffectParam::per_drive): the alternation of the shared fit
// with every drive's values held and each drive's values with the shared parameters held.
#include <spdlog/spdlog.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "evidence_priors.h"
#include "ndsid/identify/chunks.h"
#include "ndsid/identify/identifier.h"
#include "residual_sums.h"

namespace ndsid::identify {
namespace {

// The scale of a per-drive parameter: its neutral magnitude or half its box, whichever is larger
// (a load ratio: 1). Steps and tolerances of the per-drive fits are relative to it.
double PerDriveScale(const model::EffectParam& p) {
  return std::max(std::abs(p.neutral), 0.5 * (p.upper - p.lower));
}

}  // namespace

std::vector<DriveValue> Identifier::FitDriveValues(const std::vector<double>& params, const SegmentList& segments,
                                                   int64_t drive, const std::vector<int>& which, std::vector<double> x,
                                                   const std::pair<double, double>& weights) const {
  const size_t k = which.size();
  const bool yaw = weights.second > 0;
  // The drive's chunks, simulated at `params` with x in the entries `which`.
  const std::vector<Chunk> chunks = MakeChunks(segments, config_.chunk_s, config_.burn_in_s);
  // Weighted residuals (stacked: per chunk a_y, then its yaw rate) in e, one series per chunk
  // and output in series, the weighted model outputs in y.
  auto evaluate = [&](const std::vector<double>& at, std::vector<double>& y, std::vector<double>* e,
                      std::vector<std::vector<double>>* series) {
    std::vector<double> p = params;
    for (size_t j = 0; j < k; ++j) p[static_cast<size_t>(which[j])] = at[j];
    y.clear();
    if (e) e->clear();
    if (series) series->clear();
    std::vector<double> a_y, r;
    for (const Chunk& c : chunks) {
      const bool with_r = yaw && c.has_yaw_rate();
      a_y.resize(c.n);
      r.resize(c.n);
      model::SimulateModel(spec_, p.data(), wheelbase_m_, c.Inputs(), a_y.data(), nullptr, with_r ? r.data() : nullptr);
      const size_t burn = BurnInSamples(c, config_.burn_in_s);
      for (int out = 0; out < (with_r ? 2 : 1); ++out) {
        const double w = out == 0 ? weights.first : weights.second;
        std::vector<double> res;
        for (size_t t = burn; t < c.n; ++t) {
          const double model_out = out == 0 ? a_y[t] : r[t];
          const double meas = out == 0 ? c.samples[t].lat_accel_mps2 : c.samples[t].yaw_rate_radps;
          y.push_back(w * model_out);
          res.push_back(w * (meas - model_out));
        }
        if (e) e->insert(e->end(), res.begin(), res.end());
        if (series) series->push_back(std::move(res));
      }
    }
  };
  std::vector<double> scale(k), lower(k), upper(k);
  for (size_t j = 0; j < k; ++j) {
    const model::EffectParam* ep = spec_.effect_param(which[j]);
    scale[j] = PerDriveScale(*ep);
    lower[j] = ep->lower;
    upper[j] = ep->upper;
  }
  // Standstill evidence of this drive's stops on its own values (as Identify's on the vector's),
  // as a pseudo-observation in the residuals' units: level (value - x)^2 / sd^2.
  std::vector<std::pair<size_t, StandstillPrior>> evidence;
  for (const StandstillPrior& sp : StandstillPriors({drive})) {
    const bool configured = HasConfiguredPrior(config_, sp.param);
    for (size_t j = 0; j < k && !configured; ++j)
      if (spec_.param_name(which[j]) == sp.param) evidence.emplace_back(j, sp);
  }
  std::vector<double> y0, y1, e;
  std::vector<std::vector<double>> series;
  double level = 0;
  Eigen::MatrixXd ztz = Eigen::MatrixXd::Zero(static_cast<long>(k), static_cast<long>(k));
  // Sensitivities z_j = d(model)/d(x_j) by forward differences, Z'Z and Z'e.
  auto linearise = [&](Eigen::VectorXd& zte) {
    evaluate(x, y0, &e, &series);
    level = ResidualNoiseLevel(series);
    Eigen::MatrixXd z(static_cast<long>(y0.size()), static_cast<long>(k));
    for (size_t j = 0; j < k; ++j) {
      const double h = 1e-4 * std::max(std::abs(x[j]), scale[j]);
      std::vector<double> xj = x;
      xj[j] += h;
      evaluate(xj, y1, nullptr, nullptr);
      for (size_t t = 0; t < y0.size(); ++t) z(static_cast<long>(t), static_cast<long>(j)) = (y1[t] - y0[t]) / h;
    }
    ztz = z.transpose() * z;
    zte = z.transpose() * Eigen::Map<const Eigen::VectorXd>(e.data(), static_cast<long>(e.size()));
    for (const auto& [j, sp] : evidence) {
      const long jj = static_cast<long>(j);
      ztz(jj, jj) += level / (sp.sd * sp.sd);
      zte[jj] += level * (sp.value - x[j]) / (sp.sd * sp.sd);
    }
  };
  Eigen::VectorXd zte;
  for (int it = 0; it < 8; ++it) {
    linearise(zte);
    if (!(ztz.trace() > 0)) break;
    const Eigen::VectorXd step = ztz.completeOrthogonalDecomposition().solve(zte);
    double largest = 0;
    for (size_t j = 0; j < k; ++j) {
      const double next = std::clamp(x[j] + step[static_cast<long>(j)], lower[j], upper[j]);
      largest = std::max(largest, std::abs(next - x[j]) / scale[j]);
      x[j] = next;
    }
    if (largest < 1e-5) break;
  }
  linearise(zte);
  const Eigen::MatrixXd cov = ztz.completeOrthogonalDecomposition().pseudoInverse() * level;
  std::vector<DriveValue> out;
  for (size_t j = 0; j < k; ++j) {
    DriveValue v;
    v.drive_id = drive;
    v.param = spec_.param_name(which[j]);
    v.value = x[j];
    // Not determined (the drive's data do not see it, e.g. a gyro offset without a yaw rate):
    // the start value stays, with no standard error (NaN, null in JSON).
    const long jj = static_cast<long>(j);
    v.se = ztz(jj, jj) > 0 ? std::sqrt(std::max(0.0, cov(jj, jj))) : std::numeric_limits<double>::quiet_NaN();
    out.push_back(v);
  }
  return out;
}

IdentificationResult Identifier::IdentifyPerDrive(const SegmentList& training, const SegmentList& validation,
                                                  const std::optional<std::vector<double>>& warm_start) const {
  const std::vector<int>& per_drive = spec_.per_drive_params();
  std::string names;
  for (int i : per_drive) names += (names.empty() ? "" : ", ") + spec_.param_name(i);
  std::map<int64_t, SegmentList> train_drives, held_out_drives;
  for (const stats::Segment* s : training) train_drives[s->drive_id].push_back(s);
  for (const stats::Segment* s : validation) held_out_drives[s->drive_id].push_back(s);
  Identifier work = *this;  // starts from the values already set (set_drive_values)
  if (train_drives.size() < 2) {
    work.set_drive_values({});
    IdentificationResult r = work.IdentifyAtDriveValues(training, validation, warm_start);
    r.identifiability.notes.push_back("per drive (" + names + "): one training drive, no per-drive value to estimate");
    return r;
  }
  // The reference: the first training drive (the parameter vector and EG describe it).
  const int64_t reference = train_drives.begin()->first;
  std::vector<int> pinned;  // per-drive parameters with a common mode: held at neutral on the reference
  for (int i : per_drive)
    if (spec_.effect_param(i)->pinned_at_reference()) pinned.push_back(i);
  // The current value of parameter i on a drive: its override, else the vector's.
  auto current = [&](const Identifier& id, int64_t drive, int i, const std::vector<double>& vec) {
    if (const auto it = id.drive_overrides_.find(drive); it != id.drive_overrides_.end()) {
      for (const auto& [j, v] : it->second)
        if (j == i) return v;
    }
    return vec[static_cast<size_t>(i)];
  };
  auto output_weights = [](const IdentificationResult& f) {
    if (f.yaw_rate_output && f.noise_level_a_y > 0 && f.noise_level_yaw_rate > 0)
      return std::make_pair(1.0 / std::sqrt(f.noise_level_a_y), 1.0 / std::sqrt(f.noise_level_yaw_rate));
    return std::make_pair(1.0, 0.0);
  };
  std::optional<std::vector<double>> start = warm_start;
  std::vector<DriveValue> values_out;
  IdentificationResult fit;
  // Alternate: the shared parameters with every drive's values held, then each drive's values
  // with the shared parameters held. A pinned parameter is fitted on the reference drive too:
  // its value c there is the common mode (all drives alike), exactly the base parameters of its
  // EffectParam::common_mode scaled by c^power, so every drive's value is divided by c and those
  // parameters rescaled before the next shared fit. That direction, along which plain
  // alternation crawls, is taken in one step.
  for (int round = 0; round < 5; ++round) {
    fit = work.IdentifyAtDriveValues(training, {}, start);
    if (!fit.valid) return fit;
    std::vector<double> values = fit.AllValues();
    const auto weights = output_weights(fit);
    std::map<int64_t, std::vector<DriveValue>> fitted;
    for (const auto& [drive, segments] : train_drives) {
      const std::vector<int>& which = drive == reference ? pinned : per_drive;
      if (which.empty()) continue;
      std::vector<double> x;
      for (int i : which) x.push_back(current(work, drive, i, values));
      fitted[drive] = work.FitDriveValues(values, segments, drive, which, x, weights);
    }
    double worst_common = 0;
    for (int i : pinned) {
      const model::EffectParam* ep = spec_.effect_param(i);
      double c = 1;
      for (const DriveValue& v : fitted[reference])
        if (v.param == ep->name && ep->neutral != 0) c = v.value / ep->neutral;
      for (auto& [drive, list] : fitted) {
        for (DriveValue& v : list) {
          if (v.param != ep->name) continue;
          v.value /= c;
          v.se /= c;
        }
      }
      for (const model::EffectParam::Power& pw : ep->common_mode) values[static_cast<size_t>(pw.base_param)] *= std::pow(c, pw.power);
      worst_common = std::max(worst_common, std::abs(c - 1));
      spdlog::debug("per drive round {}: {} common mode {:.4f}", round, ep->name, c);
    }
    double change = 0;
    values_out.clear();
    for (const auto& [drive, list] : fitted) {
      for (DriveValue v : list) {
        const int i = spec_.param_index(v.param);
        if (drive == reference) {  // a pinned parameter: neutral on the reference after the gauge
          v.value = spec_.effect_param(i)->neutral;
          v.se = 0;
          v.reference = true;
        } else {
          change = std::max(change, std::abs(v.value - current(work, drive, i, values)) /
                                        PerDriveScale(*spec_.effect_param(i)));
        }
        values_out.push_back(v);
      }
    }
    start = values;
    work.set_drive_values(values_out);
    spdlog::debug("per drive round {}: largest change {:.4g}", round, change);
    if (change < 1e-3 && worst_common < 1e-3) break;
  }
  fit = work.IdentifyAtDriveValues(training, {}, start);
  if (!fit.valid) return fit;
  const std::vector<double> shared = fit.AllValues();
  // The reference drive's values of the parameters it fits (not pinned): the vector's.
  for (int i : per_drive) {
    if (std::find(pinned.begin(), pinned.end(), i) != pinned.end()) continue;
    const ParameterEstimate& pe = fit.effect_params[static_cast<size_t>(i - model::kNumParams)];
    values_out.push_back({reference, pe.name, pe.value, pe.se, true, false});
  }
  std::stable_sort(values_out.begin(), values_out.end(),
                   [](const DriveValue& a, const DriveValue& b) { return a.drive_id < b.drive_id; });
  // Held-out drives: their own values, fitted with the shared parameters held, then the RMSE.
  const auto weights = output_weights(fit);
  for (const auto& [drive, segments] : held_out_drives) {
    if (train_drives.count(drive)) continue;
    std::vector<double> x;
    for (int i : per_drive) x.push_back(shared[static_cast<size_t>(i)]);
    for (DriveValue v : work.FitDriveValues(shared, segments, drive, per_drive, x, weights)) {
      v.validation = true;
      values_out.push_back(v);
    }
  }
  work.set_drive_values(values_out);
  fit.drive_values = values_out;
  if (!validation.empty()) {  // both outputs' held-out RMSE from one simulation of each chunk
    const ErrorSums s = SimulatedErrorSums(
        work.spec_, work.wheelbase_m_, MakeChunks(validation, work.config_.chunk_s, work.config_.burn_in_s, work.drive_overrides_),
        shared, work.config_.burn_in_s, fit.yaw_rate_output, work.config_.threads);
    fit.residuals_validation = s.na;
    fit.rmse_validation_mps2 = RootMean(s.a, s.na);
    if (fit.yaw_rate_output) fit.rmse_validation_yaw_radps = RootMean(s.r, s.nr);
  }
  fit.identifiability.notes.push_back(
      "per drive (" + names + "): a value per drive; the parameter vector and EG describe drive " +
      std::to_string(reference) + "; the per-drive standard errors are conditional on the shared parameters");
  return fit;
}

}  // namespace ndsid::identify
