#include "ndsid/discover/diagnosis.h"

#include <spdlog/spdlog.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "ndsid/identify/chunks.h"
#include "ndsid/identify/model_output.h"

namespace ndsid::discover {
using namespace identify;  // the estimator this stage builds on
namespace {

using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

struct Signature {
  const char* name;
  double (*value)(const stats::SegmentSample* s, size_t k, size_t n, double dt, double w);
};

double SteerRate(const stats::SegmentSample* s, size_t k, size_t n, double dt) {
  const size_t a = k > 0 ? k - 1 : k, b = k + 1 < n ? k + 1 : k;
  return b > a ? (s[b].steer_rad - s[a].steer_rad) / ((b - a) * dt) : 0.0;
}

const Signature kSignatures[] = {
    {"constant (bias)", [](const stats::SegmentSample*, size_t, size_t, double, double) { return 1.0; }},
    {"a_y (scale, roll)", [](const stats::SegmentSample* s, size_t k, size_t, double, double) { return double(s[k].lat_accel_mps2); }},
    {"a_y^3 (tyre nonlinearity)", [](const stats::SegmentSample* s, size_t k, size_t, double, double) {
       const double a = s[k].lat_accel_mps2;
       return a * a * a;
     }},
    {"w(v) = v^2/(l+EG v^2) (straight-line offset)", [](const stats::SegmentSample*, size_t, size_t, double, double w) { return w; }},
    {"w(v)*a_y (EG error)", [](const stats::SegmentSample* s, size_t k, size_t, double, double w) { return w * s[k].lat_accel_mps2; }},
    {"steering rate (lag)", [](const stats::SegmentSample* s, size_t k, size_t n, double dt, double) { return SteerRate(s, k, n, dt); }},
    {"steering rate / v (low-speed lag)", [](const stats::SegmentSample* s, size_t k, size_t n, double dt, double) {
       return SteerRate(s, k, n, dt) / std::max(1.0, double(s[k].speed_mps));
     }},
    {"a_x (longitudinal)", [](const stats::SegmentSample* s, size_t k, size_t, double, double) { return double(s[k].long_accel_mps2); }},
    {"a_x*a_y (load transfer)", [](const stats::SegmentSample* s, size_t k, size_t, double, double) {
       return double(s[k].long_accel_mps2) * s[k].lat_accel_mps2;
     }},
};
constexpr int kNumSignatures = sizeof(kSignatures) / sizeof(kSignatures[0]);

// A per-drive candidate parameter (model::EffectParam::per_drive; load_change's load ratio):
// one sensitivity column per drive, g_d = d(e)/d(value) on that drive's chunks (the column of
// the candidate's parameter, restricted to the drive). Projected against the fitted parameters,
// which absorb what all drives share (for a parameter with a common mode, exactly: a common load
// is cv and ch), the joint score gives the drop in RSS of fitting a value per drive;
// significance from chi^2 = dRSS / (sigma^2 tau) on the projected columns' rank.
struct PerDriveScore {
  int col = -1;                          // the candidate's column in the big model
  bool pinned = false;                   // its common mode is in the base parameters (a load)
  std::string effect, param, unit;
  std::map<int64_t, int> index;          // drive id -> column
  std::vector<Eigen::VectorXd> a_g;      // per drive: A' g_d (all columns of big)
  std::vector<double> g_g, g_e;          // per drive: g_d' g_d, g_d' e

  void Add(int64_t drive, const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>& A,
           const Eigen::Map<const Eigen::VectorXd>& e) {
    const auto [it, added] = index.emplace(drive, static_cast<int>(index.size()));
    if (added) {
      a_g.push_back(Eigen::VectorXd::Zero(A.cols()));
      g_g.push_back(0);
      g_e.push_back(0);
    }
    const int d = it->second;
    const Eigen::VectorXd g = A.col(col);
    a_g[static_cast<size_t>(d)] += A.transpose() * g;
    g_g[static_cast<size_t>(d)] += g.squaredNorm();
    g_e[static_cast<size_t>(d)] += g.dot(e);
  }

  // M = A'A, Ae = A'e over all columns of big. Projected against the fitted parameters and, for a
  // parameter without a common mode, against its own column too: the score is the spread
  // between drives beyond one common value (which the parameter's global form would fit).
  CandidateScore Score(const Eigen::MatrixXd& M, const Eigen::VectorXd& Ae, std::vector<int> fitted, double rss,
                       size_t n, const std::vector<std::vector<double>>& residuals, double z_threshold) const {
    if (!pinned && std::find(fitted.begin(), fitted.end(), col) == fitted.end()) fitted.push_back(col);
    const int nd = static_cast<int>(index.size()), nf = static_cast<int>(fitted.size());
    Eigen::MatrixXd JtJ(nf, nf);
    Eigen::VectorXd Jte(nf);
    for (int a = 0; a < nf; ++a) {
      Jte[a] = Ae[fitted[a]];
      for (int b = 0; b < nf; ++b) JtJ(a, b) = M(fitted[a], fitted[b]);
    }
    Eigen::MatrixXd JtG(nf, nd), GtG = Eigen::MatrixXd::Zero(nd, nd);
    Eigen::VectorXd Gte(nd);
    for (int d = 0; d < nd; ++d) {
      for (int f = 0; f < nf; ++f) JtG(f, d) = a_g[static_cast<size_t>(d)][fitted[f]];
      GtG(d, d) = g_g[static_cast<size_t>(d)];
      Gte[d] = g_e[static_cast<size_t>(d)];
    }
    const Eigen::MatrixXd B = JtJ.completeOrthogonalDecomposition().solve(JtG);
    const Eigen::MatrixXd P = GtG - JtG.transpose() * B;  // projected G'G
    const Eigen::VectorXd q = Gte - B.transpose() * Jte;  // projected G'e
    const auto cod = P.completeOrthogonalDecomposition();
    const Eigen::VectorXd eta = cod.solve(q);
    CandidateScore s;
    s.effect = effect;
    s.param = param + " spread (sd over drives)";
    s.unit = unit;
    s.drss = std::max(0.0, q.dot(eta));
    s.rmse_predicted = std::sqrt(std::max(0.0, rss - s.drss) / static_cast<double>(n));
    const double mean = eta.mean();
    double var = 0;
    for (int d = 0; d < nd; ++d) var += (eta[d] - mean) * (eta[d] - mean);
    s.one_step = nd > 1 ? std::sqrt(var / (nd - 1)) : 0.0;
    s.uniqueness = GtG.trace() > 0 ? P.trace() / GtG.trace() : 0.0;
    const double sigma2_tau = ResidualNoiseLevel(residuals);
    const double dof = std::max<double>(1.0, static_cast<double>(cod.rank()));
    const double chi2 = sigma2_tau > 0 ? s.drss / sigma2_tau : 0.0;
    s.z_robust = (chi2 - dof) / std::sqrt(2 * dof);
    s.significant = s.z_robust > z_threshold;
    return s;
  }
};

// Whether two effects of the library share a parameter: alternatives (gyro_offset and
// gyro_offset_per_drive), which one model never holds together.
bool SharesParameter(const model::EffectLibrary& library, const std::string& a, const std::string& b) {
  for (const auto& p : library.Get(a)->info().params)
    for (const auto& q : library.Get(b)->info().params)
      if (p.name == q.name) return true;
  return false;
}

}  // namespace

Diagnosis Diagnose(const Identifier& identifier, const std::vector<double>& params, const SegmentList& segments,
                   const DiagnosisOptions& options) {
  Diagnosis d;
  const model::ModelSpec& spec = identifier.spec();
  d.model = spec.Describe();
  std::vector<std::string> candidates = options.candidates;
  const auto present = spec.effect_names();
  if (candidates.empty()) {
    for (const std::string& c : spec.library().builtin_names()) {
      const auto effect = spec.library().Find(c);
      if (effect == nullptr || effect->info().default_candidate) candidates.push_back(c);
    }
  }
  candidates.erase(std::remove_if(candidates.begin(), candidates.end(),
                                  [&](const std::string& c) { return std::find(present.begin(), present.end(), c) != present.end(); }),
                   candidates.end());
  // Two outputs (identification.outputs [a_y, yaw_rate]): the score tests stack both outputs'
  // residuals, each weighted by 1/sqrt(its noise level), as the fit does; yaw-rate sensor effects
  // and the ones that need the yaw rate are then candidates too.
  // With a_y alone, a yaw-rate sensor effect reaches a_y only through an effect that reads the
  // measured yaw rate (road_bank's observer turns a gyro offset into a bank): then it is scored,
  // otherwise not; accel_scale (needs the yaw rate as an output) is not.
  const bool two_outputs = identifier.config().yaw_rate_output;
  const bool reads_r = std::any_of(spec.effects().begin(), spec.effects().end(),
                                   [](const auto& e) { return e->info().reads_measured_yaw_rate; });
  if (options.candidates.empty() && !two_outputs) {
    candidates.erase(std::remove_if(candidates.begin(), candidates.end(),
                                    [&](const std::string& c) {
                                      const auto builtin = model::BuiltinEffectNames();
                                      if (std::find(builtin.begin(), builtin.end(), c) == builtin.end()) return false;
                                      const model::ModelSpec one = model::ModelSpec::FromNames({c});
                                      return !one.effects().empty() && ((one.effects()[0]->info().yaw_rate_sensor && !reads_r) ||
                                                                        one.effects()[0]->info().needs_yaw_rate_output);
                                    }),
                     candidates.end());
  }
  // One model holding every candidate at its neutral value: its Jacobian there gives the
  // fitted parameters' columns J and every candidate's sensitivity column at once.
  // Alternatives (effects sharing a parameter: gyro_offset and gyro_offset_per_drive) enter it
  // once: a per-drive candidate whose parameter the model or an earlier candidate already has is
  // scored on that column, split by drive; any other such candidate is the model's own already.
  std::vector<std::string> all = present;
  std::vector<std::pair<std::string, std::string>> alternatives;  // (per-drive candidate, its parameter)
  for (const std::string& c : candidates) {
    if (std::none_of(all.begin(), all.end(), [&](const std::string& other) { return SharesParameter(spec.library(), c, other); })) {
      all.push_back(c);
      continue;
    }
    for (const auto& p : spec.library().Get(c)->info().params)
      if (p.per_drive) alternatives.emplace_back(c, p.name);
  }
  const model::ModelSpec big = model::ModelSpec::FromNames(all, spec.library());
  const std::vector<double> x = Extend(spec, params, big);
  const int np = big.num_params();
  std::vector<int> fitted, cand;  // columns of big: fitted free parameters, candidate parameters
  std::vector<int> per_drive_cols;  // candidate per-drive parameters
  for (int i = 0; i < np; ++i) {
    const bool is_base = i < model::kNumParams;
    bool in_current = is_base;
    for (int j = model::kNumParams; j < spec.num_params() && !is_base; ++j) in_current |= spec.param_name(j) == big.param_name(i);
    const model::EffectParam* ep = big.effect_param(i);
    if (in_current) {
      if (ep && ep->pinned_at_reference()) continue;  // held at neutral on the reference drive
      if (options.hold_on_bound &&
          AtBound(x[static_cast<size_t>(i)], is_base ? identifier.config().params[i].lower : ep->lower,
                  is_base ? identifier.config().params[i].upper : ep->upper))
        continue;
      if (!(is_base && identifier.config().params[i].fixed)) fitted.push_back(i);
    } else if (ep && ep->per_drive) {
      per_drive_cols.push_back(i);  // scored per drive (PerDriveScore)
    } else {
      cand.push_back(i);
    }
  }

  const auto& cfg = identifier.config();
  // The chunks carry the current per-drive values laid out for the big model.
  const auto chunks = MakeChunks(segments, cfg.chunk_s, cfg.burn_in_s, identify::OverridesFor(identifier.drive_values(), big));
  std::vector<PerDriveScore> per_drive_scores;
  {
    std::set<int64_t> drives;
    for (const Chunk& c : chunks) drives.insert(c.drive_id);
    for (int col : per_drive_cols) {
      if (drives.size() < 2) break;
      PerDriveScore pds;
      pds.col = col;
      pds.param = big.param_name(col);
      pds.unit = big.param_unit(col);
      for (const auto& eff : big.effects())
        for (const auto& p : eff->info().params)
          if (p.name == pds.param) pds.effect = eff->info().name;
      pds.pinned = big.effect_param(col)->pinned_at_reference();
      per_drive_scores.push_back(std::move(pds));
    }
    for (const auto& [effect, param] : alternatives) {
      if (drives.size() < 2) break;
      PerDriveScore pds;
      pds.col = big.param_index(param);
      pds.param = param;
      pds.unit = big.param_unit(pds.col);
      pds.effect = effect;
      per_drive_scores.push_back(std::move(pds));
    }
  }
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(np, np);  // A'A
  Eigen::VectorXd Ae = Eigen::VectorXd::Zero(np);     // A'e
  std::vector<Eigen::VectorXd> chunk_Ae;
  std::vector<Eigen::MatrixXd> chunk_M;  // per chunk A'A (the sandwich of the one-step's standard error)
  std::vector<std::vector<double>> chunk_residuals;
  double rss = 0;
  size_t n = 0;
  // Signatures: X'X-style sums for residual correlations, clustered by chunk.
  const double eg = model::SelfSteerGradient(model::Params<double>::FromArray(params.data()), identifier.wheelbase_m());
  Eigen::MatrixXd sig_sums = Eigen::MatrixXd::Zero(kNumSignatures, 4);  // sum x, sum x^2, sum x e, (unused)
  double sum_e = 0;
  std::vector<Eigen::VectorXd> chunk_sig_xe;
  std::vector<double> chunk_e_sum, chunk_n;
  std::vector<std::vector<double>> sig_values(kNumSignatures);
  // Output weights (two outputs): 1/sqrt(sigma^2 tau) of each output's residuals at params.
  double w_a = 1.0, w_r = 1.0;
  bool stacked = false;
  if (two_outputs) {
    std::vector<std::vector<double>> ra, rr;
    for (Chunk c : chunks) {
      const size_t burn = BurnInSamples(c, cfg.burn_in_s);
      std::vector<double> e, jac;
      const auto own = identifier.drive_overrides().find(c.drive_id);  // the current model's layout
      c.drive_params = own != identifier.drive_overrides().end() ? own->second : std::vector<std::pair<int, double>>{};
      EvaluateChunk(c, burn, identifier.wheelbase_m(), spec, params, e, jac, true);
      const size_t na = c.n - burn;
      ra.emplace_back(e.begin(), e.begin() + static_cast<long>(std::min(na, e.size())));
      if (e.size() > na) rr.emplace_back(e.begin() + static_cast<long>(na), e.end());
    }
    const double la = ResidualNoiseLevel(ra), lr = ResidualNoiseLevel(rr);
    if (la > 0 && lr > 0 && std::isfinite(la) && std::isfinite(lr)) {
      w_a = 1.0 / std::sqrt(la);
      w_r = 1.0 / std::sqrt(lr);
      stacked = true;
      d.outputs = "a_y and yaw rate";
    }
  }
  double rss_a = 0;    // a_y, unweighted
  double rss_sig = 0;  // a_y as scored (weighted)
  size_t n_a_total = 0;
  for (const Chunk& c : chunks) {
    const size_t burn = BurnInSamples(c, cfg.burn_in_s);
    std::vector<double> e, jac;
    EvaluateChunk(c, burn, identifier.wheelbase_m(), big, x, e, jac, stacked);
    const size_t n_rows_a = std::min(c.n - burn, e.size());
    for (size_t k = 0; k < n_rows_a; ++k) rss_a += e[k] * e[k];
    n_a_total += n_rows_a;
    if (stacked) {
      for (size_t k = 0; k < e.size(); ++k) {
        const double w = k < n_rows_a ? w_a : w_r;
        e[k] *= w;
        for (int j = 0; j < np; ++j) jac[k * static_cast<size_t>(np) + static_cast<size_t>(j)] *= w;
      }
    }
    const int m = static_cast<int>(e.size());
    for (size_t k = 0; k < n_rows_a; ++k) rss_sig += e[k] * e[k];
    Eigen::Map<const RowMajor> A(jac.data(), m, np);
    Eigen::Map<const Eigen::VectorXd> ev(e.data(), m);
    chunk_M.push_back(A.transpose() * A);
    M += chunk_M.back();
    for (PerDriveScore& pds : per_drive_scores) pds.Add(c.drive_id, A, ev);
    const Eigen::VectorXd ae = A.transpose() * ev;
    Ae += ae;
    chunk_Ae.push_back(ae);
    rss += ev.squaredNorm();
    n += static_cast<size_t>(m);
    chunk_residuals.push_back(e);
    Eigen::VectorXd xe = Eigen::VectorXd::Zero(kNumSignatures);
    double esum = 0;
    for (int k = 0; k < static_cast<int>(n_rows_a); ++k) {
      const size_t kk = burn + static_cast<size_t>(k);
      const double v = c.samples[kk].speed_mps;
      const double w = v * v / (identifier.wheelbase_m() + eg * v * v);
      esum += e[static_cast<size_t>(k)];
      for (int s = 0; s < kNumSignatures; ++s) {
        const double val = kSignatures[s].value(c.samples, kk, c.n, c.dt_s, w);
        sig_sums(s, 0) += val;
        sig_sums(s, 1) += val * val;
        xe[s] += val * e[static_cast<size_t>(k)];
      }
    }
    sum_e += esum;
    chunk_sig_xe.push_back(xe);
    chunk_e_sum.push_back(esum);
    chunk_n.push_back(m);
  }
  d.residuals = n;
  if (n == 0) return d;
  d.rmse = n_a_total > 0 ? std::sqrt(rss_a / static_cast<double>(n_a_total)) : 0.0;  // a_y, unweighted
  // Standstill evidence (docs/two-outputs.md): each prior Identify would use becomes one
  // pseudo-observation sqrt(w) (value - x) / sd of its parameter, in the a_y residuals' units (w
  // their noise level sigma^2 tau), and its own cluster in the robust variance. So a standing
  // car's mean a_y speaks for accel_bias in the ranking as it does in the fit. Its cluster's
  // variance is the model-based one, w a a' (under the null its residual has variance w, the
  // stops' standard error being in sd), not the realised (a r)^2: one cluster that carries a
  // strong signal alone would make its own realised score the whole variance and hold |z| at
  // about 1 however clear the evidence (a hidden 0.4 deg/s gyro offset read z -1.1 that way).
  std::vector<Eigen::VectorXd> evidence_rows;
  double evidence_w = 0;
  const double noise_level = ResidualNoiseLevel(chunk_residuals);  // sigma^2 tau of the residuals as scored
  {
    std::set<int64_t> drives;
    for (const Chunk& c : chunks) drives.insert(c.drive_id);
    const double w = noise_level;
    for (const Identifier::StandstillPrior& sp : identifier.StandstillPriors(drives)) {
      int col = -1;
      for (int i = model::kNumParams; i < np; ++i)
        if (big.param_name(i) == sp.param) col = i;
      if (col < 0 || !(w > 0)) continue;
      Eigen::VectorXd a = Eigen::VectorXd::Zero(np);
      a[col] = -std::sqrt(w) / sp.sd;
      const double r = std::sqrt(w) * (sp.value - x[static_cast<size_t>(col)]) / sp.sd;
      M += a * a.transpose();
      Ae += a * r;
      evidence_rows.push_back(a);
      evidence_w = w;
      d.evidence.push_back(sp);
    }
  }

  // Projection against the fitted parameters: b = (J'J)^-1 J'g for every candidate column.
  const int nf = static_cast<int>(fitted.size()), nc = static_cast<int>(cand.size());
  Eigen::MatrixXd JtJ(nf, nf), JtG(nf, nc), GtG(nc, nc);
  Eigen::VectorXd Jte(nf), Gte(nc);
  for (int a = 0; a < nf; ++a) {
    Jte[a] = Ae[fitted[a]];
    for (int b = 0; b < nf; ++b) JtJ(a, b) = M(fitted[a], fitted[b]);
    for (int b = 0; b < nc; ++b) JtG(a, b) = M(fitted[a], cand[b]);
  }
  for (int a = 0; a < nc; ++a) {
    Gte[a] = Ae[cand[a]];
    for (int b = 0; b < nc; ++b) GtG(a, b) = M(cand[a], cand[b]);
  }
  const Eigen::MatrixXd B = JtJ.completeOrthogonalDecomposition().solve(JtG);  // nf x nc
  const Eigen::MatrixXd Gt_Gt = GtG - JtG.transpose() * B;                      // projected G'G
  const Eigen::VectorXd Gt_e = Gte - B.transpose() * Jte;                       // projected G'e
  for (int a = 0; a < nc; ++a) {
    CandidateScore s;
    const int col = cand[a];
    const model::EffectParam* ep = big.effect_param(col);
    for (const auto& eff : big.effects()) {
      for (const auto& p : eff->info().params) {
        if (p.name == ep->name) s.effect = eff->info().name;
      }
    }
    s.param = ep->name;
    s.unit = ep->unit;
    const double ztz = Gt_Gt(a, a), zte = Gt_e[a];
    s.uniqueness = GtG(a, a) > 0 ? ztz / GtG(a, a) : 0.0;
    if (ztz > 1e-12 * std::max(1.0, GtG(a, a))) {
      s.drss = zte * zte / ztz;
      s.one_step = ep->neutral - zte / ztz;
    }
    s.rmse_predicted = std::sqrt(std::max(0.0, rss - s.drss) / static_cast<double>(n));
    // The projected column z = e_col - sum_f B(f,a) e_fitted: per chunk, its score z'A'e and its
    // information z'A'Az.
    Eigen::VectorXd z = Eigen::VectorXd::Zero(np);
    z[col] = 1.0;
    for (int f = 0; f < nf; ++f) z[fitted[f]] -= B(f, a);
    double var = 0, var_at_estimate = 0;
    for (size_t k = 0; k < chunk_Ae.size(); ++k) {
      const double sc = z.dot(chunk_Ae[k]);
      var += sc * sc;
      if (ztz > 0) {  // at the one-step estimate: the chunks' scores sum to zero
        const double at = sc - z.dot(chunk_M[k] * z) * zte / ztz;
        var_at_estimate += at * at;
      }
    }
    double var_evidence = 0;
    for (const auto& row : evidence_rows) {
      const double sc = z.dot(row);
      var_evidence += evidence_w * sc * sc;
    }
    s.z_robust = var + var_evidence > 0 ? zte / std::sqrt(var + var_evidence) : 0.0;
    // The one-step's standard error, as the fit's covariance: model-based, or the cluster sandwich
    // at the estimate where that is larger.
    const double g = static_cast<double>(chunk_Ae.size());
    if (s.drss > 0 && noise_level > 0 && std::isfinite(noise_level) && g > 1) {
      const double sandwich = var_at_estimate * g / (g - 1) + var_evidence;
      s.se = std::max(std::sqrt(noise_level / ztz), std::sqrt(sandwich) / ztz);
    }
    s.significant = std::abs(s.z_robust) > options.z_threshold;
    // What it trades with: fitted parameters carrying most of its sensitivity, and candidates
    // whose projected sensitivities are nearly parallel to its own.
    if (s.uniqueness < 0.2) {
      for (int f = 0; f < nf; ++f) {
        const double share = std::abs(B(f, a)) * std::sqrt(JtJ(f, f) / std::max(GtG(a, a), 1e-300));
        if (share > 0.3) s.confounded_with.push_back(big.param_name(fitted[f]));
      }
    }
    for (int b = 0; b < nc; ++b) {
      if (b == a || Gt_Gt(a, a) <= 0 || Gt_Gt(b, b) <= 0) continue;
      const double corr = Gt_Gt(a, b) / std::sqrt(Gt_Gt(a, a) * Gt_Gt(b, b));
      if (std::abs(corr) > 0.9) s.confounded_with.push_back(big.param_name(cand[b]));
    }
    d.ranked.push_back(s);
  }
  for (const PerDriveScore& pds : per_drive_scores) {
    d.ranked.push_back(pds.Score(M, Ae, fitted, rss, n, chunk_residuals, options.z_threshold));
  }
  // The a_y RMSE a candidate predicts: the stacked (weighted) RSS falls by drss, the a_y RMSE in
  // proportion (with one output exactly sqrt((rss - drss) / n)).
  for (CandidateScore& c : d.ranked) c.rmse_predicted = rss > 0 ? d.rmse * std::sqrt(std::max(0.0, 1.0 - c.drss / rss)) : 0.0;
  std::sort(d.ranked.begin(), d.ranked.end(), [](const auto& a, const auto& b) { return a.drss > b.drss; });

  // Residual correlations with the signature signals (centred), clustered by chunk.
  // (On the a_y residuals: weighted as scored, the yaw-rate rows excluded.)
  const double n_sig = static_cast<double>(n_a_total);
  const double mean_e = n_sig > 0 ? sum_e / n_sig : 0.0;
  for (int s = 0; s < kNumSignatures; ++s) {
    SignatureCorrelation sc;
    sc.signal = kSignatures[s].name;
    const double mean_x = n_sig > 0 ? sig_sums(s, 0) / n_sig : 0.0;
    const double sxx = sig_sums(s, 1) - n_sig * mean_x * mean_x;
    double sxe = 0, var = 0;
    for (size_t c = 0; c < chunk_sig_xe.size(); ++c) {
      // sum over chunk of (x - mean_x)(e - mean_e) = xe - mean_x*esum - mean_e*sum_x + n mean_x mean_e; use
      // the uncentred-x form with centred e (exact when summed over all chunks).
      const double part = chunk_sig_xe[c][s] - mean_e * 0.0 - mean_x * chunk_e_sum[c];
      sxe += part;
      var += part * part;
    }
    if (sxx > 0 && rss_sig > 0) {
      const double see = rss_sig - n_sig * mean_e * mean_e;
      sc.correlation = sxe / std::sqrt(sxx * std::max(see, 1e-300));
      sc.drss = sxe * sxe / sxx;
      sc.z_robust = var > 0 ? sxe / std::sqrt(var) : 0.0;
    }
    d.signatures.push_back(sc);
  }
  std::sort(d.signatures.begin(), d.signatures.end(), [](const auto& a, const auto& b) { return a.drss > b.drss; });

  // Unexplained: a significant signature explains clearly more than the best significant candidate.
  double best_candidate = 0;
  for (const auto& c : d.ranked) {
    if (c.significant) best_candidate = std::max(best_candidate, c.drss);
  }
  if (!d.signatures.empty()) {
    const auto& top = d.signatures.front();
    if (std::abs(top.z_robust) > options.z_threshold && top.drss > 2.0 * best_candidate && top.drss > 0.01 * rss) {
      d.unexplained = true;
      char buf[256];
      std::snprintf(buf, sizeof buf,
                    "residual structure no library effect explains: it correlates with %s (r = %.2f, z = %.1f, "
                    "explains %.1f %% of the RSS)",
                    top.signal.c_str(), top.correlation, top.z_robust, 100 * top.drss / rss);
      d.unexplained_text = buf;
    }
  }
  return d;
}

std::vector<OutputVerdict> JudgeOutputs(const Identifier& identifier, const std::vector<double>& params,
                                        const SegmentList& segments, bool yaw_rate_output, double ratio_limit,
                                        double yaw_shift_samples) {
  struct Sums {
    double ss = 0, dd = 0;
    size_t n = 0, nd = 0;
    void Add(const std::vector<double>& e) {
      for (size_t k = 0; k < e.size(); ++k) {
        ss += e[k] * e[k];
        if (k > 0) dd += (e[k] - e[k - 1]) * (e[k] - e[k - 1]);
      }
      n += e.size();
      nd += e.empty() ? 0 : e.size() - 1;
    }
  } a, r;
  for (const identify::ChunkOutput& c : identify::SimulateChunks(identifier, params, segments)) {
    std::vector<double> ea, er;
    bool yaw_finite = yaw_rate_output && c.yaw_rate_model_radps.size() == c.n;
    for (size_t k = c.burn_in; k < c.n; ++k) {
      const stats::SegmentSample& s = c.segment->samples[c.first + k];
      ea.push_back(static_cast<double>(s.lat_accel_mps2) - c.a_y_model_mps2[k]);
      if (yaw_finite) {
        const double e = static_cast<double>(s.yaw_rate_radps) - c.yaw_rate_model_radps[k];
        yaw_finite = std::isfinite(e);
        er.push_back(e);
      }
    }
    a.Add(ea);
    if (yaw_finite) r.Add(er);
  }
  std::vector<OutputVerdict> out;
  // White noise read at a fraction w between samples, (1-w) e_k + w e_k+1, has first differences
  // of variance 2 g(w), g(w) = ((1-w)^2 + (1-2w)^2 + w^2) / 2 (1 at w = 0): the floor is divided
  // by sqrt(g). Measured: a 45 ms yaw-rate shift at 50 Hz (w 0.27) read the yaw rate 1.54x its
  // floor uncorrected.
  const double w = yaw_shift_samples - std::floor(yaw_shift_samples);
  const double g_yaw = ((1 - w) * (1 - w) + (1 - 2 * w) * (1 - 2 * w) + w * w) / 2;
  auto judge = [&](const Sums& s, const char* name, const char* unit, double to_unit, double g = 1.0) {
    if (s.nd == 0) return;
    OutputVerdict v;
    v.output = name;
    v.unit = unit;
    v.residuals = s.n;
    v.rmse = to_unit * std::sqrt(s.ss / static_cast<double>(s.n));
    v.floor = to_unit * std::sqrt(s.dd / (2.0 * static_cast<double>(s.nd)) / g);
    v.ratio = v.floor > 0 ? v.rmse / v.floor : 0.0;
    v.unexplained = v.floor > 0 && v.ratio > ratio_limit;
    char buf[400];
    if (v.unexplained) {
      std::snprintf(buf, sizeof buf,
                    "%s unexplained: held-out RMSE %.4g %s is %.2fx its noise floor %.4g %s (white part of the residual, "
                    "limit %.2fx): structure is left that no effect of the model explains (an effect outside the "
                    "library, or a sensor whose noise is not white, e.g. filtered)",
                    name, v.rmse, unit, v.ratio, v.floor, unit, ratio_limit);
    } else {
      std::snprintf(buf, sizeof buf, "%s explained: held-out RMSE %.4g %s is %.2fx its noise floor %.4g %s (limit %.2fx)",
                    name, v.rmse, unit, v.ratio, v.floor, unit, ratio_limit);
    }
    v.text = buf;
    out.push_back(v);
  };
  judge(a, "a_y", "m/s^2", 1.0);
  judge(r, "yaw rate", "deg/s", 180.0 / M_PI, g_yaw);
  return out;
}

Ladder ClimbErrorLadder(const config::IdentificationConfig& config, double wheelbase_m,
                        const std::vector<std::string>& start_effects, const model::EffectLibrary& library,
                        const SegmentList& training_in,
                        const SegmentList& validation_in, const LadderOptions& options) {
  Ladder ladder;
  std::vector<std::string> effects = start_effects;
  Identifier current(config, wheelbase_m, model::ModelSpec::FromNames(effects, library));
  current.set_standstill(options.standstill);
  const bool given = options.start_fit && options.start_fit->valid && options.start_fit->model == current.spec().Describe();
  IdentificationResult fit =
      given ? *options.start_fit : current.Identify(training_in, validation_in, std::optional<std::vector<double>>{});
  current.set_drive_values(fit.drive_values);
  if (!fit.valid) {
    ladder.rungs.push_back({current.spec().Describe(), "", fit, 0.0});
    ladder.stop_reason = "the starting model could not be fitted: " + fit.reason;
    return ladder;
  }
  // Step 0: time alignment. The ladder then works on shifted copies of the data.
  std::vector<stats::Segment> aligned_training, aligned_validation;
  SegmentList training = training_in, validation = validation_in;
  if (options.align) {
    ladder.before_alignment = fit;
    ladder.alignment = EstimateRoleLatencies(current, fit.AllValues(), training_in, options.alignment);
    for (const RoleLatency& l : ladder.alignment) ladder.aligned = ladder.aligned || l.apply;
    if (ladder.aligned) {
      aligned_training = AlignSegments(training_in, ladder.alignment);
      aligned_validation = AlignSegments(validation_in, ladder.alignment);
      training = Pointers(aligned_training);
      validation = Pointers(aligned_validation);
      const IdentificationResult refit = current.Identify(training, validation, std::optional<std::vector<double>>(fit.AllValues()));
      if (refit.valid) {
        fit = refit;
        current.set_drive_values(fit.drive_values);
      } else {  // keep the data as recorded
        ladder.aligned = false;
        for (RoleLatency& l : ladder.alignment) l.apply = false;
        training = training_in;
        validation = validation_in;
      }
    }
  }
  ladder.rungs.push_back({current.spec().Describe(), "", fit, 0.0});
  auto held_out = [](const IdentificationResult& r) { return r.rmse_validation_mps2 >= 0 ? r.rmse_validation_mps2 : r.rmse_train_mps2; };
  auto held_out_yaw = [](const IdentificationResult& r) {
    return r.rmse_validation_yaw_radps >= 0 ? r.rmse_validation_yaw_radps : r.rmse_train_yaw_radps;
  };
  // The speed scale read from a_x (LadderOptions::speed_scale_evidence): a prior on speed_scale
  // for every fit below, and speed_scale itself first when the evidence says the speed is scaled.
  config::IdentificationConfig ladder_config = config;
  const stats::SpeedScaleEvidence& sse = options.speed_scale_evidence;
  const bool has_speed_prior = std::any_of(config.priors.begin(), config.priors.end(),
                                           [](const config::ParameterPrior& p) { return p.name == "speed_scale"; });
  // The current model with one more effect, refitted from the current fit, as every trial is.
  auto refit = [&](const std::vector<std::string>& trial) {
    Identifier next(ladder_config, wheelbase_m, model::ModelSpec::FromNames(trial, library));
    next.set_standstill(options.standstill);
    next.set_drive_values(fit.drive_values);  // per-drive parameters: start from the current values
    IdentificationResult f2 =
        next.Identify(training, validation, std::optional<std::vector<double>>(Extend(current.spec(), fit.AllValues(), next.spec())));
    return std::make_pair(std::move(next), std::move(f2));
  };
  // How far a refit moves EG from the current fit: relative, and in the refit's sigma.
  auto record_eg_shift = [&](Trial& t, const IdentificationResult& f2) {
    t.eg_shift_rel = fit.eg_rad_per_mps2 != 0 ? (f2.eg_rad_per_mps2 - fit.eg_rad_per_mps2) / std::abs(fit.eg_rad_per_mps2) : 0.0;
    t.eg_shift_sigma = f2.eg_se_rad_per_mps2 > 0 ? (f2.eg_rad_per_mps2 - fit.eg_rad_per_mps2) / f2.eg_se_rad_per_mps2 : 0.0;
  };
  // A refit becomes the ladder's next rung.
  auto climb = [&](const std::vector<std::string>& trial, const Identifier& next, const IdentificationResult& f2,
                   const std::string& added, double dbic) {
    effects = trial;
    current = next;
    fit = f2;
    current.set_drive_values(fit.drive_values);
    ladder.rungs.push_back({current.spec().Describe(), added, fit, dbic});
  };
  if (sse.available && !has_speed_prior) {
    const double sd = sse.prior_sd;
    ladder_config.priors.push_back({"speed_scale", sse.scale, sd, "the speed signal against a_x (ndsid diagnose)"});
    const auto& cands = options.diagnosis.candidates;
    const bool candidate = cands.empty() || std::find(cands.begin(), cands.end(), "speed_scale") != cands.end();
    const bool in_model = std::find(effects.begin(), effects.end(), "speed_scale") != effects.end();
    if (candidate && !in_model && library.Find("speed_scale") && std::abs(sse.scale) > options.speed_scale_add_sigma * sd) {
      std::vector<std::string> trial = effects;
      trial.push_back("speed_scale");
      const auto [next, f2] = refit(trial);
      Trial t;
      t.step = 0;
      t.effect = "speed_scale";
      t.held_out_before = held_out(fit);
      char why[320];
      if (!f2.valid) {
        t.why = "fit not valid: " + f2.reason;
      } else {
        t.held_out_after = held_out(f2);
        const bool both = fit.yaw_rate_output && f2.yaw_rate_output;
        if (both) t.yaw_before = held_out_yaw(fit), t.yaw_after = held_out_yaw(f2);
        record_eg_shift(t, f2);
        t.accepted = t.held_out_after <= 1.01 * t.held_out_before && (!both || t.yaw_after <= 1.01 * t.yaw_before);
        char yaw[48] = "";
        if (both) std::snprintf(yaw, sizeof yaw, ", yaw rate %+.1f %%", 100 * (t.yaw_after / t.yaw_before - 1));
        std::snprintf(why, sizeof why,
                      "%s (evidence from a_x: %+.2f +- %.2f %%, prior sd %.2f %%): held-out RMSE %+.1f %%%s; EG %+.2f %% (%+.1f sigma)",
                      t.accepted ? "added" : "rejected, a held-out RMSE rose by more than 1 %", 100 * sse.scale, 100 * sse.se,
                      100 * sd, 100 * (t.held_out_after / t.held_out_before - 1), yaw, 100 * t.eg_shift_rel, t.eg_shift_sigma);
        t.why = why;
      }
      spdlog::info("ladder: + speed_scale: {}", t.why);
      ladder.trials.push_back(t);
      if (t.accepted) climb(trial, next, f2, "speed_scale", 0.0);
    }
  }
  for (int step = 0; step < options.max_steps; ++step) {
    Diagnosis diag = Diagnose(current, fit.AllValues(), training, options.diagnosis);
    ladder.diagnoses.push_back(diag);
    bool improved = false;
    int tried = 0;
    // Candidates that pass only the EG-relevant rule (LadderOptions): kept for after the loop.
    struct EgRelevant {
      size_t trial;       // index into ladder.trials
      double dbic;        // both outputs' BIC change: the strongest evidence wins
      std::vector<std::string> effects;
      Identifier model;
      IdentificationResult fit;
    };
    std::vector<EgRelevant> eg_relevant;
    // Alternatives: a global form (gyro_offset) whose per-drive form's spread between drives is
    // significant is followed at once by that per-drive form. The global one is tried first: its
    // refit is judged on held-out drives, and when the quantity differs between drives a value
    // for all makes those drives worse; then the per-drive form, which fits theirs. (Ranked by
    // its spread alone, the per-drive form can come too late: its spread is only clean once the
    // common value is fitted.)
    auto shares_param = [&](const std::string& a, const std::string& b) { return SharesParameter(library, a, b); };
    auto per_drive_form = [&](const std::string& e) {
      for (const auto& p : library.Get(e)->info().params)
        if (p.per_drive) return true;
      return false;
    };
    std::vector<CandidateScore> order;
    for (const CandidateScore& c : diag.ranked) {
      if (std::any_of(order.begin(), order.end(), [&](const CandidateScore& o) { return o.effect == c.effect; })) continue;
      order.push_back(c);
      if (!c.significant || per_drive_form(c.effect)) continue;
      for (const CandidateScore& a : diag.ranked) {
        if (a.significant && per_drive_form(a.effect) && shares_param(a.effect, c.effect) &&
            std::none_of(order.begin(), order.end(), [&](const CandidateScore& o) { return o.effect == a.effect; }))
          order.push_back(a);
      }
    }
    for (const CandidateScore& c : order) {
      const bool large = c.rmse_predicted < (1.0 - options.large_effect_rmse_drop) * diag.rmse;
      if ((!c.significant && !large) || tried >= 3) continue;
      ++tried;
      // An alternative of an effect in the model (gyro_offset_per_drive for gyro_offset) replaces it.
      std::vector<std::string> trial;
      for (const std::string& e : effects)
        if (!shares_param(e, c.effect)) trial.push_back(e);
      trial.push_back(c.effect);
      const auto [next, f2] = refit(trial);
      Trial trial_record;
      trial_record.step = static_cast<int>(ladder.rungs.size()) - 1;  // the rung refitted on
      trial_record.effect = c.effect;
      trial_record.held_out_before = held_out(fit);
      if (!f2.valid) {
        trial_record.why = "fit not valid: " + f2.reason;
        ladder.trials.push_back(trial_record);
        continue;
      }
      const double before = held_out(fit), after = held_out(f2);
      // BIC with an effective sample size (residuals are autocorrelated): n_eff = n / tau, tau
      // the integrated autocorrelation time of the refit's own residuals (the one noise
      // estimate, ResidualNoiseLevel = sigma^2 tau, as the covariance uses it); with two outputs
      // each output's term, on its own residuals.
      auto tau = [](double noise_level, double rmse) {
        const double t = rmse > 0 ? noise_level / (rmse * rmse) : 0.0;
        return std::isfinite(t) && t >= 1.0 ? t : 1.0;
      };
      const double n_eff = static_cast<double>(f2.residuals_train) / tau(f2.noise_level_a_y, f2.rmse_train_mps2);
      const bool both = fit.yaw_rate_output && f2.yaw_rate_output && fit.rmse_train_yaw_radps > 0 && f2.rmse_train_yaw_radps > 0;
      const double n_eff_r =
          both ? static_cast<double>(f2.residuals_train_yaw) / tau(f2.noise_level_yaw_rate, f2.rmse_train_yaw_radps) : 0.0;
      spdlog::debug("ladder: + {}: effective samples {:.0f} (tau {:.1f})", c.effect, n_eff,
                    static_cast<double>(f2.residuals_train) / std::max(n_eff, 1.0));
      double dbic = n_eff * std::log((f2.rmse_train_mps2 * f2.rmse_train_mps2) / (fit.rmse_train_mps2 * fit.rmse_train_mps2)) +
                    (static_cast<double>(f2.NumEstimated()) - static_cast<double>(fit.NumEstimated())) * std::log(std::max(n_eff + n_eff_r, 2.0));
      if (both) dbic += n_eff_r * std::log((f2.rmse_train_yaw_radps * f2.rmse_train_yaw_radps) / (fit.rmse_train_yaw_radps * fit.rmse_train_yaw_radps));
      // Effect size on held-out data: one output falls by min_relative_improvement, the other
      // does not rise by more than 1 % (a gyro error shows in the yaw rate, a roll in a_y).
      bool better = after < before * (1.0 - options.min_relative_improvement);
      if (both) {
        const double yb = held_out_yaw(fit), ya = held_out_yaw(f2);
        spdlog::info("ladder: + {}: held-out yaw-rate RMSE {:.4f} -> {:.4f} deg/s", c.effect, yb * 180 / M_PI, ya * 180 / M_PI);
        better = (better && ya < 1.01 * yb) || (ya < yb * (1.0 - options.min_relative_improvement) && after < 1.01 * before);
      }
      spdlog::info("ladder: + {}: held-out RMSE {:.4f} -> {:.4f}, dBIC {:.1f}", c.effect, before, after, dbic);
      trial_record.held_out_after = after;
      trial_record.delta_bic = dbic;
      if (both) trial_record.yaw_before = held_out_yaw(fit), trial_record.yaw_after = held_out_yaw(f2);
      // A prior on the added effect's parameter (model.priors, or the speed scale read from a_x):
      // a refit that lands more than 3 prior sd from it stands in for another effect.
      std::string contradicts;
      for (const identify::ParameterEstimate& p : f2.effect_params) {
        for (const config::ParameterPrior& pr : ladder_config.priors) {
          if (pr.name != p.name || !(pr.sd > 0) || std::abs(p.value - pr.value) <= 3 * pr.sd) continue;
          bool before_too = false;  // only the parameters the candidate adds
          for (const identify::ParameterEstimate& q : fit.effect_params) before_too = before_too || q.name == p.name;
          if (before_too) continue;
          char buf[200];
          std::snprintf(buf, sizeof buf, "%s = %.4g lies %.1f prior sd from its prior %.4g +- %.2g (%s)", p.name.c_str(), p.value,
                        std::abs(p.value - pr.value) / pr.sd, pr.value, pr.sd, pr.location.c_str());
          contradicts = buf;
        }
      }
      if (!contradicts.empty()) better = false;
      trial_record.accepted = better && dbic < 0;
      // The EG-relevant rule (LadderOptions): both outputs, neither rises, one falls by 1 %, the
      // BIC falls, EG moves by more than 5 sigma and 1 %.
      bool eg_moves = false;
      record_eg_shift(trial_record, f2);
      const double eg_shift_rel = trial_record.eg_shift_rel, eg_shift_sigma = trial_record.eg_shift_sigma;
      if (both && !trial_record.accepted) {
        const double yb = held_out_yaw(fit), ya = held_out_yaw(f2);
        const double fall = std::max(1.0 - after / before, 1.0 - ya / yb);
        eg_moves = contradicts.empty() && after <= before && ya <= yb && fall >= options.eg_relevant_min_improvement && dbic < 0 &&
                   std::abs(eg_shift_sigma) > options.eg_relevant_shift_sigma &&
                   std::abs(eg_shift_rel) > options.eg_relevant_shift_rel;
      }
      {
        char why[320];
        const double rel = 100 * (after / before - 1);
        if (trial_record.accepted) {
          std::snprintf(why, sizeof why, "added: held-out RMSE %+.1f %%, dBIC %.1f", rel, dbic);
        } else if (!better) {
          std::snprintf(why, sizeof why, "rejected: held-out RMSE %+.1f %% (needs %+.1f %%%s)", rel,
                        -100 * options.min_relative_improvement, both ? " on one output, the other <= +1 %" : "");
        } else {
          std::snprintf(why, sizeof why, "rejected: dBIC %+.1f (needs < 0) although the held-out RMSE fell %+.1f %%", dbic, rel);
        }
        trial_record.why = why;
        if (!contradicts.empty()) trial_record.why = "rejected: it contradicts its prior, " + contradicts;
        if (both && !trial_record.accepted) {
          std::snprintf(why, sizeof why, "; EG %+.2f %% (%+.1f sigma)%s", 100 * eg_shift_rel, eg_shift_sigma,
                        eg_moves ? ", held-out falls and EG moves: EG-relevant" : "");
          trial_record.why += why;
        }
      }
      ladder.trials.push_back(trial_record);
      if (eg_moves) eg_relevant.push_back({ladder.trials.size() - 1, dbic, trial, next, f2});
      if (better && dbic < 0) {
        climb(trial, next, f2, c.effect, dbic);
        improved = true;
        break;
      }
    }
    if (!improved && !eg_relevant.empty()) {
      // No candidate met the RMSE rule; one moves EG far beyond its uncertainty while both
      // held-out errors fall. Members of a confounded group (roll, the sensor scales) can all pass;
      // the one the training data of both outputs support most (lowest BIC) is added.
      const auto best = std::min_element(eg_relevant.begin(), eg_relevant.end(),
                                         [](const EgRelevant& a, const EgRelevant& b) { return a.dbic < b.dbic; });
      Trial& t = ladder.trials[best->trial];
      t.accepted = true;
      char why[320];
      std::snprintf(why, sizeof why, "added (EG-relevant): held-out RMSE %+.1f %%, yaw rate %+.1f %%, dBIC %.1f; EG %+.2f %% (%+.1f sigma)",
                    100 * (t.held_out_after / t.held_out_before - 1), 100 * (t.yaw_after / t.yaw_before - 1), t.delta_bic,
                    100 * t.eg_shift_rel, t.eg_shift_sigma);
      t.why = why;
      spdlog::info("ladder: + {}: {}", t.effect, t.why);
      climb(best->effects, best->model, best->fit, t.effect, t.delta_bic);
      improved = true;
    }
    if (!improved) {
      if (tried == 0) {
        ladder.stop_reason = "no significant candidate left";
      } else {
        ladder.stop_reason = "no candidate improved the held-out RMSE enough (tried:";
        for (const Trial& t : ladder.trials)
          if (t.step == static_cast<int>(ladder.rungs.size()) - 1) ladder.stop_reason += " " + t.effect + (&t == &ladder.trials.back() ? "" : ",");
        ladder.stop_reason += ")";
      }
      break;
    }
  }
  if (ladder.stop_reason.empty()) ladder.stop_reason = "step limit reached";
  // EG settled? The refits on top of the final model that were not added but move EG beyond its
  // uncertainty. (When the step limit ended the ladder, nothing was refitted on the final model.)
  const int final_step = static_cast<int>(ladder.rungs.size()) - 1;
  for (const Trial& t : ladder.trials) {
    if (t.step != final_step || t.accepted || t.held_out_after <= 0) continue;
    if (std::abs(t.eg_shift_rel) <= options.eg_relevant_shift_rel || std::abs(t.eg_shift_sigma) <= options.eg_unsettled_sigma)
      continue;
    char part[200];
    std::snprintf(part, sizeof part, "%s%s moves it %+.2f %% (%+.1f sigma; held-out RMSE %+.1f %%)",
                  ladder.eg_unsettled.empty() ? "" : ", ", t.effect.c_str(), 100 * t.eg_shift_rel, t.eg_shift_sigma,
                  100 * (t.held_out_after / t.held_out_before - 1));
    ladder.eg_unsettled += part;
  }
  if (!ladder.eg_unsettled.empty()) {
    ladder.eg_unsettled = "EG not settled: refitted on the final model and not added, " + ladder.eg_unsettled +
                          ". EG depends on a model choice the ladder's rules did not make (a confounded group, or an "
                          "effect too small in the error to add): a prior on the effect (model.priors) or more varied "
                          "driving decides it";
    spdlog::warn("ladder: {}", ladder.eg_unsettled);
  }
  double yaw_shift_samples = 0;
  const SegmentList& judged = validation.empty() ? training : validation;
  for (const RoleLatency& l : ladder.alignment) {
    if (l.apply && l.role == config::Role::kYawRate && !judged.empty() && judged.front()->dt_s > 0)
      yaw_shift_samples = l.latency_s / judged.front()->dt_s;
  }
  ladder.verdicts = JudgeOutputs(current, fit.AllValues(), judged, fit.yaw_rate_output, options.unexplained_ratio,
                                 yaw_shift_samples);
  for (const OutputVerdict& v : ladder.verdicts) spdlog::info("ladder: {}", v.text);
  return ladder;
}

}  // namespace ndsid::discover
