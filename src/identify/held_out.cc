#include "held_out.h"

#include <spdlog/spdlog.h>

#include <Eigen/Dense>
#include <algorithm>
#include <map>
#include <utility>

#include "parallel.h"
#include "residual_sums.h"

namespace ndsid::identify {
namespace {

// Each chunk's sums at x from its quadratic, per output (the yaw rate's part kept apart; none
// with a_y alone), added in segment and chunk order; the RMSEs into r.
void SumQuadratics(const std::vector<LinearizedSegment>& held_lin, const Eigen::Ref<const Eigen::VectorXd>& x,
                   bool two_outputs, IdentificationResult& r) {
  const long np = x.size();
  double sa = 0, sr = 0;
  size_t na = 0, nr = 0;
  for (const LinearizedSegment& ls : held_lin) {
    for (const LinearizedChunk& c : ls.chunks) {
      const Eigen::VectorXd d = x - Eigen::Map<const Eigen::VectorXd>(c.theta.data(), np);
      const Eigen::Map<const RowMajorMatrix> hall(c.jtj.data(), np, np);
      const Eigen::Map<const Eigen::VectorXd> sall(c.score.data(), np);
      double qr = 0, ga = sall.dot(d), qa = d.dot(hall * d), gr = 0;
      if (!c.jtj_yaw_rate.empty()) {
        const Eigen::Map<const RowMajorMatrix> hr(c.jtj_yaw_rate.data(), np, np);
        gr = Eigen::Map<const Eigen::VectorXd>(c.score_yaw_rate.data(), np).dot(d);
        qr = d.dot(hr * d);
        ga -= gr;
        qa -= qr;
      }
      sa += std::max(0.0, c.rss_a_y + 2 * ga + qa);
      sr += std::max(0.0, c.rss_yaw_rate + 2 * gr + qr);
      na += c.n_a_y;
      nr += c.n_yaw_rate;
    }
  }
  r.residuals_validation = na;
  r.rmse_validation_mps2 = RootMean(sa, na);
  if (two_outputs) r.rmse_validation_yaw_radps = RootMean(sr, nr);
}

}  // namespace

bool HeldOutFromQuadratics(const FitSettings& settings, const ParameterBox& box, const SegmentList& validation,
                           const std::vector<double>& theta, const IncrementalPrior* prior, double sigma_rule,
                           bool two_outputs, std::vector<LinearizedSegment>& held_lin, IdentificationResult& r) {
  const int np = box.size();
  std::map<std::pair<int64_t, int64_t>, const LinearizedSegment*> held_prior;
  if (prior)
    for (const LinearizedSegment& ls : prior->window().held_out) held_prior[{ls.drive_id, ls.t0_ns}] = &ls;
  Eigen::MatrixXd h;
  double level = 0;
  if (!held_prior.empty()) {
    h = prior->Jtj();
    level = prior->Level();
  }
  const Eigen::Map<const Eigen::VectorXd> x(theta.data(), np);
  auto near = [&](const LinearizedSegment& ls) {
    return level > 0 && !IncrementalPrior::DistanceOf(ls, x, h, level).beyond(sigma_rule);
  };
  held_lin.resize(validation.size());
  std::vector<std::vector<Chunk>> cuts(validation.size());
  std::vector<std::pair<size_t, size_t>> jobs;  // (held-out segment, chunk) simulated with the Jacobian
  size_t reused = 0;
  for (size_t i = 0; i < validation.size(); ++i) {
    const stats::Segment* seg = validation[i];
    if (!seg) continue;
    held_lin[i].drive_id = seg->drive_id;
    held_lin[i].t0_ns = seg->t0_ns;
    held_lin[i].samples = seg->samples.size();
    const auto it = held_prior.find({seg->drive_id, seg->t0_ns});
    if (it != held_prior.end() && SameSegment(*it->second, *seg) && near(*it->second)) {
      held_lin[i].chunks = it->second->chunks;
      reused += it->second->chunks.size();
      continue;
    }
    cuts[i] = settings.Cut(seg);
    held_lin[i].chunks.resize(cuts[i].size());
    for (size_t k = 0; k < cuts[i].size(); ++k) jobs.emplace_back(i, k);
  }
  const auto unit = std::make_shared<OutputWeights>(OutputWeights{1.0, two_outputs ? 1.0 : 0.0});
  std::vector<char> ok(jobs.size(), 0);
  ParallelFor(jobs.size(), settings.config.threads, [&](size_t j) {
    const auto [i, k] = jobs[j];
    const Chunk& c = cuts[i][k];
    std::vector<double> e, jac;
    if (!settings.EvaluateAt(c, box.scale, unit, theta, e, jac)) return;
    const long m = static_cast<long>(e.size());
    const Eigen::Map<const RowMajorMatrix> J(jac.data(), m, np);
    const Eigen::Map<const Eigen::VectorXd> ev(e.data(), m);
    Linearize(held_lin[i].chunks[k], theta, e, J, J.transpose() * J, J.transpose() * ev, c.n - settings.BurnIn(c), *unit,
              two_outputs, false);
    ok[j] = 1;
  });
  if (!std::all_of(ok.begin(), ok.end(), [](char v) { return v != 0; })) {
    held_lin.clear();
    return false;
  }
  SumQuadratics(held_lin, x, two_outputs, r);
  r.held_out_from_prior = reused;
  r.held_out_linearized = jobs.size();
  spdlog::debug("held-out RMSE: {} chunks from their quadratics, {} simulated with their Jacobian", reused, jobs.size());
  return true;
}

void HeldOutBySimulation(const FitSettings& settings, const SegmentList& validation, bool two_outputs, IdentificationResult& r) {
  const config::IdentificationConfig& config = settings.config;
  const ErrorSums s = SimulatedErrorSums(settings.spec, settings.wheelbase_m,
                                         MakeChunks(validation, config.chunk_s, config.burn_in_s, settings.drive_overrides),
                                         r.AllValues(), config.burn_in_s, two_outputs, config.threads);
  r.residuals_validation = s.na;
  r.rmse_validation_mps2 = RootMean(s.a, s.na);
  if (two_outputs) r.rmse_validation_yaw_radps = RootMean(s.r, s.nr);
}

}  // namespace ndsid::identify
