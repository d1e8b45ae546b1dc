#include "incremental_prior.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>

#include "parallel.h"
#include "residual_sums.h"

namespace ndsid::identify {

bool SameSegment(const LinearizedSegment& l, const stats::Segment& s) {
  return l.drive_id == s.drive_id && l.t0_ns == s.t0_ns && l.samples == s.samples.size();
}

IncrementalPrior::IncrementalPrior(const FitSettings& settings, const LinearizedWindow& window, const std::vector<double>& theta0)
    : settings_(settings),
      np_(settings.spec.num_params()),
      window_(&window),
      theta0_(theta0),
      quadratic_(settings.spec.num_params()) {}

SegmentList IncrementalPrior::Split(const SegmentList& training) {
  SegmentList simulated;
  std::map<std::pair<int64_t, int64_t>, const LinearizedSegment*> by_key;
  for (const LinearizedSegment& ls : window_->segments) by_key[{ls.drive_id, ls.t0_ns}] = &ls;
  for (const stats::Segment* seg : training) {
    const auto it = seg ? by_key.find({seg->drive_id, seg->t0_ns}) : by_key.end();
    if (it != by_key.end() && SameSegment(*it->second, *seg)) {
      segments_.push_back({seg, it->second});
    } else {
      simulated.push_back(seg);
    }
  }
  return simulated;
}

size_t IncrementalPrior::NumChunks() const {
  size_t n = 0;
  for (const Segment& ps : segments_) n += ps.lin->chunks.size();
  return n;
}

size_t IncrementalPrior::ChunksWithYawRate() const {
  size_t n = 0;
  for (const Segment& ps : segments_) n += ps.seg->has_yaw_rate ? ps.lin->chunks.size() : 0;
  return n;
}

double IncrementalPrior::PoolSums(std::vector<double>& acf) const {
  double n = 0;
  for (const Segment& ps : segments_) {
    for (const LinearizedChunk& c : ps.lin->chunks) {
      AddSums(c.acf_a_y, acf);
      AddSums(c.acf_yaw_rate, acf);
      n += c.n_a_y + c.n_yaw_rate;
    }
  }
  return n;
}

double IncrementalPrior::Level() const {
  std::vector<double> acf(kAcfMaxLag + 1, 0.0);
  const double n = PoolSums(acf);
  return LevelOfSums(acf, n);
}

Eigen::MatrixXd IncrementalPrior::Jtj() const {
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(np_, np_);
  for (const Segment& ps : segments_) {
    for (const LinearizedChunk& c : ps.lin->chunks) h += Eigen::Map<const RowMajorMatrix>(c.jtj.data(), np_, np_);
  }
  return h;
}

IncrementalPrior::Distance IncrementalPrior::DistanceOf(const LinearizedSegment& ls, const Eigen::Ref<const Eigen::VectorXd>& x,
                                                        const Eigen::MatrixXd& h, double level) {
  const long np = x.size();
  Distance out;
  for (const LinearizedChunk& c : ls.chunks) {
    const Eigen::VectorXd d = x - Eigen::Map<const Eigen::VectorXd>(c.theta.data(), np);
    const double m = d.dot(h * d) / level;
    if (out.worst_d.size() == 0 || m > out.worst) out.worst_d = d;
    out.worst = std::max(out.worst, m);
    out.step = std::max(out.step, d.lpNorm<Eigen::Infinity>());
  }
  return out;
}

std::vector<size_t> IncrementalPrior::StaleSegments(const std::vector<double>& at, double rule, const Moments& pm) const {
  std::vector<size_t> out;
  if (segments_.empty()) return out;
  const Eigen::MatrixXd& h = pm.h;
  const double level = pm.level;
  if (!(level > 0)) return out;
  const Eigen::Map<const Eigen::VectorXd> x(at.data(), np_);
  for (size_t i = 0; i < segments_.size(); ++i) {
    const Distance dist = DistanceOf(*segments_[i].lin, x, h, level);
    if (dist.beyond(rule)) {
      // For the log: the parameter whose own move (in its marginal sigma) is the largest.
      Eigen::Index most = 0;
      (dist.worst_d.cwiseAbs().array() * h.diagonal().cwiseMax(0.0).array().sqrt()).maxCoeff(&most);
      spdlog::debug("incremental: prior segment {} stale ({:.3g} sigma, step {:.3g}; largest single move {})", i,
                    std::sqrt(dist.worst), dist.step, settings_.spec.param_name(static_cast<int>(most)));
      out.push_back(i);
    }
  }
  return out;
}

bool IncrementalPrior::CheckedNear(const std::vector<double>& theta, const Moments& pm) const {
  if (window_->checked_at.size() != static_cast<size_t>(np_) || segments_.size() != window_->segments.size()) return false;
  if (!(pm.level > 0)) return false;
  const Eigen::VectorXd d = Eigen::Map<const Eigen::VectorXd>(theta.data(), np_) -
                            Eigen::Map<const Eigen::VectorXd>(window_->checked_at.data(), np_);
  const double m = d.dot(pm.h * d) / pm.level;
  if (!(m <= kRecheckSigma * kRecheckSigma)) return false;
  spdlog::debug("incremental: EG check skipped: the solution lies {:.2g} sigma from where the same quadratics passed it", std::sqrt(m));
  return true;
}

void IncrementalPrior::Repoint(const LinearizedWindow& copy) {
  for (Segment& ps : segments_) ps.lin = &copy.segments[static_cast<size_t>(ps.lin - window_->segments.data())];
  window_ = &copy;
}

void IncrementalPrior::ReweightToWindow(FitProblem& fit, bool two_outputs) {
  if (!two_outputs || segments_.empty() || !window_->Reweightable()) return;
  OutputWeights& weights = *fit.weights;
  const LinearizedWindow& prior = *window_;
  weights = {1.0, 1.0};
  std::vector<std::vector<double>> a, rr;
  fit.EvaluateSeries(a, rr);
  weights = {prior.weight_a_y, prior.weight_yaw_rate};
  std::vector<double> acf_a(kAcfMaxLag + 1, 0.0), acf_r(kAcfMaxLag + 1, 0.0);
  double na = AddSeriesSums(a, acf_a);
  double nr = AddSeriesSums(rr, acf_r);
  const double ua = 1.0 / (prior.weight_a_y * prior.weight_a_y);
  const double ur = 1.0 / (prior.weight_yaw_rate * prior.weight_yaw_rate);
  for (const Segment& ps : segments_) {
    for (const LinearizedChunk& c : ps.lin->chunks) {
      AddSums(c.acf_a_y, acf_a, ua);
      AddSums(c.acf_yaw_rate, acf_r, ur);
      na += c.n_a_y;
      nr += c.n_yaw_rate;
    }
  }
  const double la = LevelOfSums(acf_a, na), lr = LevelOfSums(acf_r, nr);
  if (!(la > 0 && lr > 0 && std::isfinite(la) && std::isfinite(lr))) return;
  const double wa = 1.0 / std::sqrt(la), wr = 1.0 / std::sqrt(lr);
  if (wr / wa == prior.weight_yaw_rate / prior.weight_a_y) return;
  spdlog::debug("incremental: the prior re-weighted from the weight ratio {:.4g} to the whole window's {:.4g}",
                prior.weight_yaw_rate / prior.weight_a_y, wr / wa);
  reweighted_ = std::make_shared<const LinearizedWindow>(prior.Reweighted(wa, wr));
  Repoint(*reweighted_);
  weights = {wa, wr};
}

bool IncrementalPrior::Relinearize(const std::vector<size_t>& stale, const std::vector<double>& theta,
                                   const std::vector<double>& scale, const std::shared_ptr<const OutputWeights>& weights,
                                   bool two_outputs, size_t& count) {
  if (stale.empty()) return true;
  if (!relinearized_) {
    relinearized_ = std::make_shared<LinearizedWindow>(*window_);
    Repoint(*relinearized_);
  }
  std::vector<std::vector<Chunk>> cuts;
  std::vector<std::pair<const Chunk*, LinearizedChunk*>> jobs;
  cuts.reserve(stale.size());
  for (size_t i : stale) {
    cuts.push_back(settings_.Cut(segments_[i].seg));
    auto& lin_chunks = relinearized_->segments[static_cast<size_t>(segments_[i].lin - relinearized_->segments.data())].chunks;
    if (cuts.back().size() != lin_chunks.size()) return false;
    for (size_t k = 0; k < lin_chunks.size(); ++k) jobs.emplace_back(&cuts.back()[k], &lin_chunks[k]);
  }
  std::vector<char> ok(jobs.size(), 0);
  ParallelFor(jobs.size(), settings_.config.threads, [&](size_t j) {
    const Chunk& c = *jobs[j].first;
    std::vector<double> e, jac;
    if (!settings_.EvaluateAt(c, scale, weights, theta, e, jac)) return;
    const long m = static_cast<long>(e.size());
    const Eigen::Map<const RowMajorMatrix> J(jac.data(), m, np_);
    const Eigen::Map<const Eigen::VectorXd> ev(e.data(), m);
    Linearize(*jobs[j].second, theta, e, J, J.transpose() * J, J.transpose() * ev, c.n - settings_.BurnIn(c), *weights,
              two_outputs);
    ok[j] = 1;
  });
  count += jobs.size();
  return std::all_of(ok.begin(), ok.end(), [](char x) { return x != 0; });
}

void IncrementalPrior::SetQuadratic() {
  std::vector<const LinearizedChunk*> lin;
  for (const Segment& ps : segments_)
    for (const LinearizedChunk& c : ps.lin->chunks) lin.push_back(&c);
  quadratic_.Set(lin, Level(), theta0_);
}

}  // namespace ndsid::identify
