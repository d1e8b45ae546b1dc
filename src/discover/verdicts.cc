#include "verdicts.h"

#include <cmath>
#include <cstdio>

#include "ndsid/common/format.h"
#include "ndsid/identify/model_output.h"

namespace ndsid::discover {
namespace {

// One output's residuals: the sum of squares and of squared first differences within chunks.
struct ResidualSums {
  double ss = 0;  // sum e_k^2
  double dd = 0;  // sum (e_k - e_k-1)^2 within chunks
  double mm = 0;  // sum y_k^2 of the measured output
  size_t n = 0;   // residuals
  size_t nd = 0;  // first differences
  void Add(const std::vector<double>& e, const std::vector<double>& y) {
    for (size_t k = 0; k < e.size(); ++k) {
      ss += e[k] * e[k];
      mm += y[k] * y[k];
      if (k > 0) dd += (e[k] - e[k - 1]) * (e[k] - e[k - 1]);
    }
    n += e.size();
    nd += e.empty() ? 0 : e.size() - 1;
  }
};

// The verdict on one output; g: the floor's correction for a read between samples (1: none);
// slow: its factor for a role slower than the fit (1: none).
OutputVerdict Judge(const ResidualSums& s, const char* name, const char* unit, double to_unit, const LadderOptions& o, double g,
                    double slow, const char* which) {
  const double ratio_limit = o.unexplained_ratio;
  OutputVerdict v;
  v.output = name;
  v.unit = unit;
  v.residuals = s.n;
  v.rmse = to_unit * std::sqrt(s.ss / static_cast<double>(s.n));
  v.floor = slow * to_unit * std::sqrt(s.dd / (2.0 * static_cast<double>(s.nd)) / g);
  v.spread = to_unit * std::sqrt(s.mm / static_cast<double>(s.n));
  v.ratio = v.floor > 0 ? v.rmse / v.floor : 0.0;
  const bool negligible = v.spread > 0 && v.rmse <= o.negligible_spread_ratio * v.spread;
  v.unexplained = v.floor > 0 && v.ratio > ratio_limit && !negligible;
  char buf[400];
  if (v.unexplained) {
    std::snprintf(buf, sizeof buf,
                  "%s unexplained: %s RMSE %.4g %s is %.2fx its noise floor %.4g %s (white part of the residual, "
                  "limit %.2fx): structure is left that no effect of the model explains (an effect outside the "
                  "library, or a sensor whose noise is not white, e.g. filtered)",
                  name, which, v.rmse, unit, v.ratio, v.floor, unit, ratio_limit);
  } else {
    std::snprintf(buf, sizeof buf, "%s explained: %s RMSE %.4g %s is %.2fx its noise floor %.4g %s (limit %.2fx)",
                  name, which, v.rmse, unit, v.ratio, v.floor, unit, ratio_limit);
  }
  v.text = buf;
  if (negligible && v.ratio > ratio_limit)
    v.text += Fmt(": %.2g of its spread %.4g %s, negligible whatever the floor (noise-free or filtered data)",
                  v.rmse / v.spread, v.spread, unit);
  if (slow > 1) v.text += Fmt(" (its floor x %.2f: its values come %.2f fit samples apart)", slow, slow);
  return v;
}

}  // namespace

std::vector<OutputVerdict> JudgeOutputs(const identify::Identifier& identifier, const std::vector<double>& params,
                                        const identify::SegmentList& segments, bool yaw_rate_output,
                                        const LadderOptions& options, double yaw_shift_samples, bool held_out) {
  const char* which = held_out ? "held-out" : "training (no drive held out)";
  ResidualSums a, r;
  for (const identify::ChunkOutput& c : identify::SimulateChunks(identifier, params, segments)) {
    std::vector<double> ea, er, ya, yr;
    bool yaw_finite = yaw_rate_output && c.yaw_rate_model_radps.size() == c.n;
    for (size_t k = c.burn_in; k < c.n; ++k) {
      const stats::SegmentSample& s = c.segment->samples[c.first + k];
      ya.push_back(static_cast<double>(s.lat_accel_mps2));
      ea.push_back(ya.back() - c.a_y_model_mps2[k]);
      if (yaw_finite) {
        yr.push_back(static_cast<double>(s.yaw_rate_radps));
        const double e = yr.back() - c.yaw_rate_model_radps[k];
        yaw_finite = std::isfinite(e);
        er.push_back(e);
      }
    }
    a.Add(ea, ya);
    if (yaw_finite) r.Add(er, yr);
  }
  std::vector<OutputVerdict> out;
  // White noise read at a fraction w between samples, (1-w) e_k + w e_k+1, has first differences
  // of variance 2 g(w), g(w) = ((1-w)^2 + (1-2w)^2 + w^2) / 2 (1 at w = 0): the floor is divided
  // by sqrt(g). Measured: a 45 ms yaw-rate shift at 50 Hz (w 0.27) read the yaw rate 1.54x its
  // floor uncorrected.
  const double w = yaw_shift_samples - std::floor(yaw_shift_samples);
  const double g_yaw = ((1 - w) * (1 - w) + (1 - 2 * w) * (1 - 2 * w) + w * w) / 2;
  if (a.nd > 0) out.push_back(Judge(a, "a_y", "m/s^2", 1.0, options, 1.0, options.a_y_floor_factor, which));
  if (r.nd > 0) out.push_back(Judge(r, "yaw rate", "deg/s", 180.0 / M_PI, options, g_yaw, options.yaw_floor_factor, which));
  return out;
}

bool LeavesEgUnsettled(const Trial& t, int final_step, const LadderOptions& options) {
  if (t.step != final_step || t.accepted || t.removal || t.held_out_after <= 0) return false;
  const double ratio = options.eg_unsettled_rmse_ratio;
  if (t.held_out_after > ratio * t.held_out_before || (t.yaw_before > 0 && t.yaw_after > ratio * t.yaw_before))
    return false;  // the held-out data reject this model: it does not unsettle EG
  return !(std::abs(t.eg_shift_rel) <= options.eg_relevant_shift_rel || std::abs(t.eg_shift_sigma) <= options.eg_unsettled_sigma);
}

std::vector<const Trial*> TrialsLeavingEgUnsettled(const Ladder& ladder, const LadderOptions& options) {
  std::vector<const Trial*> out;
  const int final_step = static_cast<int>(ladder.rungs.size()) - 1;
  for (const Trial& t : ladder.trials)
    if (LeavesEgUnsettled(t, final_step, options)) out.push_back(&t);
  return out;
}

std::string DescribeUnsettledEg(const Ladder& ladder, const LadderOptions& options) {
  std::string moves;
  for (const Trial* tp : TrialsLeavingEgUnsettled(ladder, options)) {
    const Trial& t = *tp;
    char part[200];
    std::snprintf(part, sizeof part, "%s%s moves it %+.2f %% (%+.1f sigma; held-out RMSE %+.1f %%)", moves.empty() ? "" : ", ",
                  t.effect.c_str(), 100 * t.eg_shift_rel, t.eg_shift_sigma, 100 * (t.held_out_after / t.held_out_before - 1));
    moves += part;
  }
  if (moves.empty()) return "";
  return "EG not settled: refitted on the final model and not added, " + moves +
         ". EG depends on a model choice the ladder's rules did not make (a confounded group, or an "
         "effect too small in the error to add): a prior on the effect (model.priors) or more varied "
         "driving decides it";
}

double YawShiftSamples(const std::vector<RoleLatency>& alignment, const identify::SegmentList& judged) {
  double samples = 0;
  for (const RoleLatency& l : alignment) {
    if (l.apply && l.role == config::Role::kYawRate && !judged.empty() && judged.front()->dt_s > 0)
      samples = l.latency_s / judged.front()->dt_s;
  }
  return samples;
}

}  // namespace ndsid::discover
