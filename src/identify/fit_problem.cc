#include "fit_problem.h"

#include <algorithm>
#include <cmath>

#include "parallel.h"

namespace ndsid::identify {

std::vector<Chunk> FitSettings::Cut(const stats::Segment* segment) const {
  return MakeChunks({segment}, config.chunk_s, config.burn_in_s, drive_overrides);
}

std::unique_ptr<ChunkCost> FitSettings::CostOf(const Chunk& c, const std::vector<double>& scale,
                                               std::shared_ptr<const OutputWeights> w) const {
  return MakeChunkCost(c, BurnIn(c), wheelbase_m, spec, scale, std::move(w));
}

bool FitSettings::EvaluateAt(const Chunk& c, const std::vector<double>& scale, std::shared_ptr<const OutputWeights> w,
                             const std::vector<double>& theta, std::vector<double>& e, std::vector<double>& jac) const {
  const auto cost = CostOf(c, scale, std::move(w));
  const size_t m = static_cast<size_t>(cost->num_residuals());
  e.resize(m);
  jac.resize(m * theta.size());
  const double* pp[] = {theta.data()};
  double* jj[] = {jac.data()};
  const auto finite = [](double x) { return std::isfinite(x); };
  return cost->Evaluate(pp, e.data(), jj) && std::all_of(e.begin(), e.end(), finite) && std::all_of(jac.begin(), jac.end(), finite);
}

ParameterBox ParameterBox::Make(const config::IdentificationConfig& config, const model::ModelSpec& spec) {
  const int np = spec.num_params();
  ParameterBox box;
  box.bounds.resize(static_cast<size_t>(np));
  box.scale.resize(static_cast<size_t>(np));
  for (int i = 0; i < np; ++i) {
    if (i < model::kNumParams) {
      const auto& c = config.params[i];
      box.bounds[i] = {c.lower, c.upper, c.initial, c.fixed};
      box.scale[i] = c.initial;
    } else {
      const model::EffectParam* e = spec.effect_param(i);
      // A per-drive parameter with a common mode is neutral on the reference drive (effect.h).
      if (e->pinned_at_reference()) {
        box.bounds[i] = {e->lower, e->upper, e->neutral, true};
      } else {
        box.bounds[i] = {e->lower, e->upper, e->initial, false};
      }
      for (const auto& [name, value] : config.fixed_effect_params)
        if (name == e->name) box.bounds[i] = {e->lower, e->upper, std::clamp(value, e->lower, e->upper), true};
      box.scale[i] = 0.5 * (e->upper - e->lower);
    }
  }
  for (int i = 0; i < np; ++i) (box.bounds[i].fixed ? box.fixed : box.free).push_back(i);
  return box;
}

std::vector<bool> ParameterBox::FixedFlags() const {
  std::vector<bool> out(bounds.size());
  for (size_t i = 0; i < bounds.size(); ++i) out[i] = bounds[i].fixed;
  return out;
}

std::vector<double> ParameterBox::Start(const std::optional<std::vector<double>>& warm_start) const {
  const int np = size();
  std::vector<double> theta(static_cast<size_t>(np));
  for (int i = 0; i < np; ++i) {
    double v = bounds[i].initial;
    if (warm_start && i < static_cast<int>(warm_start->size()) && !bounds[i].fixed) v = (*warm_start)[i];
    theta[i] = std::clamp(v, bounds[i].lower, bounds[i].upper) / scale[i];
  }
  return theta;
}

void ParameterBox::Constrain(ceres::Problem& problem, double* theta) const {
  const int np = size();
  for (int i = 0; i < np; ++i) {
    problem.SetParameterLowerBound(theta, i, bounds[i].lower / scale[i]);
    problem.SetParameterUpperBound(theta, i, bounds[i].upper / scale[i]);
  }
  if (!fixed.empty()) problem.SetManifold(theta, new ceres::SubsetManifold(np, fixed));
}

ceres::Problem::Options FitProblem::ProblemOptions() {
  ceres::Problem::Options options;
  options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  return options;
}

FitProblem::FitProblem(const FitSettings& settings_in, const std::vector<double>& scale_in, double* theta_in)
    : settings(settings_in), scale(scale_in), theta(theta_in), problem(ProblemOptions()) {}

void FitProblem::Cut(const SegmentList& segments) {
  for (const stats::Segment* seg : segments) {
    for (const Chunk& c : settings.Cut(seg)) {
      chunks.push_back(c);
      chunk_segment.push_back(seg);
    }
  }
}

void FitProblem::AddCosts() {
  costs.reserve(chunks.size());
  for (const Chunk& c : chunks) {
    const size_t burn = settings.BurnIn(c);
    costs.push_back(std::make_unique<CompressedChunkCost>(settings.CostOf(c, scale, weights), weights));
    problem.AddResidualBlock(costs.back().get(), nullptr, theta);
    n_res += static_cast<size_t>(costs.back()->full().num_residuals());
    n_a.push_back(c.n - burn);
    n_res_a += c.n - burn;
  }
}

void FitProblem::KeepLastWithin(size_t bytes) {
  const size_t np = scale.size();
  size_t total = 0;
  for (const auto& c : costs) total += static_cast<size_t>(c->full().num_residuals()) * (np + 1) * sizeof(double);
  if (total <= bytes)
    for (auto& c : costs) c->keep_last(true);
}

size_t FitProblem::ChunksWithYawRate() const {
  size_t n = 0;
  for (const Chunk& c : chunks) n += c.has_yaw_rate() ? 1 : 0;
  return n;
}

void FitProblem::EvaluateSeries(std::vector<std::vector<double>>& a, std::vector<std::vector<double>>& r) const {
  a.clear();
  r.clear();
  const double* params[] = {theta};
  std::vector<std::vector<double>> e(costs.size());
  ParallelFor(costs.size(), settings.config.threads, [&](size_t c) {
    e[c].resize(static_cast<size_t>(costs[c]->full().num_residuals()));
    costs[c]->full().Evaluate(params, e[c].data(), nullptr);
  });
  for (size_t c = 0; c < costs.size(); ++c) {
    a.emplace_back(e[c].begin(), e[c].begin() + static_cast<long>(n_a[c]));
    if (e[c].size() > n_a[c]) r.emplace_back(e[c].begin() + static_cast<long>(n_a[c]), e[c].end());
    std::vector<double>().swap(e[c]);
  }
}

double FitProblem::NoiseLevel() const {
  std::vector<std::vector<double>> a, r;
  EvaluateSeries(a, r);
  a.insert(a.end(), r.begin(), r.end());
  return ResidualNoiseLevel(a, settings.config.threads);
}

bool FitProblem::EstimateWeights(bool two_outputs) {
  if (!two_outputs) return false;
  const OutputWeights old = *weights;
  *weights = {1.0, 1.0};
  std::vector<std::vector<double>> a, rr;
  EvaluateSeries(a, rr);
  const double level_a = ResidualNoiseLevel(a, settings.config.threads);
  const double level_r = ResidualNoiseLevel(rr, settings.config.threads);
  if (!(level_a > 0) || !(level_r > 0) || !std::isfinite(level_a) || !std::isfinite(level_r)) {
    *weights = old;
    return false;
  }
  *weights = {1.0 / std::sqrt(level_a), 1.0 / std::sqrt(level_r)};
  const double ratio_old = old.yaw_rate / old.a_y, ratio_new = weights->yaw_rate / weights->a_y;
  return ratio_new * ratio_new > 1.5 * ratio_old * ratio_old || ratio_new * ratio_new < ratio_old * ratio_old / 1.5;
}

}  // namespace ndsid::identify
