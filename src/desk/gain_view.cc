// The signed view of "where it fails" (model_report.h): per 5 m/s speed band, the gain error of
// the residual on the modelled output, e = c + k y_model, fitted by least squares with an
// intercept (the bias columns of the bins carry the even part); its standard error clustered by
// chunk (neighbouring samples of a chunk are not independent). Bands whose gains differ more than
// their errors allow (chi-square against the weighted mean gain, 0.999) show a gain that changes
// with speed.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include <nlohmann/json.hpp>

#include "model_report.h"
#include "ndsid/adequacy/prior_check.h"
#include "ndsid/common/format.h"

namespace ndsid::desk {
namespace {

constexpr double kBandWidth_mps = 5.0;
constexpr int kBands = 9;  // 0-5 ... 35-40, and >40

int BandOf(double v) {
  if (!(v >= 0)) return -1;
  return std::min(kBands - 1, static_cast<int>(v / kBandWidth_mps));
}

std::string BandLabel(int b) {
  if (b == kBands - 1) return Fmt(">%g", b * kBandWidth_mps);
  return Fmt("%g-%g", b * kBandWidth_mps, (b + 1) * kBandWidth_mps);
}

// One band's samples: (modelled output, residual, chunk).
struct BandSamples {
  std::vector<double> y, e;
  std::vector<int> chunk;
};

GainBand FitBand(const BandSamples& s, const std::string& label) {
  GainBand g;
  g.label = label;
  g.n = s.y.size();
  std::map<int, int> chunks;
  for (int c : s.chunk) ++chunks[c];
  g.clusters = static_cast<int>(chunks.size());
  if (g.n < kMinBinSamples || g.clusters < 2) return g;
  double my = 0, me = 0;
  for (size_t i = 0; i < g.n; ++i) my += s.y[i], me += s.e[i];
  my /= static_cast<double>(g.n), me /= static_cast<double>(g.n);
  double syy = 0, sye = 0;
  for (size_t i = 0; i < g.n; ++i) syy += (s.y[i] - my) * (s.y[i] - my), sye += (s.y[i] - my) * (s.e[i] - me);
  if (!(syy > 0)) return g;
  g.gain = sye / syy;
  // Cluster-robust (sandwich) variance: sum over chunks of (sum of y~ u)^2 / syy^2, G/(G-1).
  std::map<int, double> score;
  for (size_t i = 0; i < g.n; ++i) {
    const double yt = s.y[i] - my, u = (s.e[i] - me) - g.gain * yt;
    score[s.chunk[i]] += yt * u;
  }
  double v = 0;
  for (const auto& [c, sc] : score) v += sc * sc;
  const double G = static_cast<double>(g.clusters);
  g.se = std::sqrt(v * G / (G - 1.0)) / syy;
  g.judged = g.clusters >= kGainMinChunks;
  g.flagged = g.judged && std::abs(g.gain) > kGainZ * g.se && std::abs(g.gain) > kGainMin;
  return g;
}

}  // namespace

GainView ComputeGainView(const std::vector<SampleRow>& rows, size_t models, bool yaw) {
  GainView view;
  for (size_t m = 0; m < models; ++m) {
    std::vector<BandSamples> bands(kBands);
    for (const SampleRow& r : rows) {
      const int b = BandOf(r.speed_mps);
      if (!r.scored || b < 0) continue;
      const double y = yaw ? r.yaw_model[m] * 180.0 / M_PI : r.ay_model[m];
      const double e = yaw ? (r.yaw_rate_radps - r.yaw_model[m]) * 180.0 / M_PI : r.ay_mps2 - r.ay_model[m];
      if (!std::isfinite(y) || !std::isfinite(e)) continue;
      bands[b].y.push_back(y), bands[b].e.push_back(e), bands[b].chunk.push_back(r.chunk);
    }
    std::vector<GainBand> out;
    double sw = 0, swk = 0, lo = INFINITY, hi = -INFINITY;
    for (int b = 0; b < kBands; ++b) {
      out.push_back(FitBand(bands[b], BandLabel(b)));
      const GainBand& g = out.back();
      if (!g.judged || !(g.se > 0)) continue;
      sw += 1 / (g.se * g.se), swk += g.gain / (g.se * g.se);
      lo = std::min(lo, g.gain), hi = std::max(hi, g.gain);
    }
    // Do the judged bands share one gain? chi2 of each against the weighted mean; a dependence
    // on speed is reported when that fails and the gains lie more than kGainMin apart.
    double chi2 = 0;
    int judged = 0;
    for (const GainBand& g : out) {
      if (!g.judged || !(g.se > 0)) continue;
      chi2 += std::pow((g.gain - swk / sw) / g.se, 2), ++judged;
    }
    view.per_model.push_back(std::move(out));
    view.chi2.push_back(chi2);
    view.dof.push_back(std::max(0, judged - 1));
    view.speed_dependent.push_back(judged >= 2 && chi2 > adequacy::Chi2Quantile999(static_cast<size_t>(judged - 1)) &&
                                   hi - lo > kGainMin);
  }
  return view;
}

void PrintGainView(const GainView& view, const std::vector<FittedModel>& models, const char* output) {
  std::printf("\nsigned view: gain error k of the %s residual on the modelled %s per speed band (e = c + k y_model), "
              "± clustered SE; * flagged (|k| > %.0f SE and > %.0f %%); ~ fewer than %d chunks, not judged\n",
              output, output, kGainZ, 100 * kGainMin, kGainMinChunks);
  std::printf("%-12s", "v [m/s]");
  for (const auto& m : models) std::printf(" | %-8s %9s %8s %6s", m.label.c_str(), "k [%]", "se [%]", "n");
  std::printf("\n");
  for (size_t b = 0; !view.per_model.empty() && b < view.per_model[0].size(); ++b) {
    std::printf("%-12s", view.per_model[0][b].label.c_str());
    for (const auto& bands : view.per_model) {
      const GainBand& g = bands[b];
      if (std::isfinite(g.gain))
        std::printf(" | %-8s %+8.2f%s %8.2f %6zu", "", 100 * g.gain, g.flagged ? "*" : g.judged ? " " : "~", 100 * g.se, g.n);
      else std::printf(" | %-8s %9s %8s %6zu", "", "too few", "", g.n);
    }
    std::printf("\n");
  }
  for (size_t m = 0; m < models.size() && m < view.chi2.size(); ++m) {
    if (view.dof[m] < 1) continue;
    const bool differ = view.chi2[m] > adequacy::Chi2Quantile999(static_cast<size_t>(view.dof[m]));
    std::printf("%-8s the bands' gains %s: chi2 %.1f on %d dof (0.999 quantile %.1f)%s\n", models[m].label.c_str(),
                view.speed_dependent[m] ? "CHANGE WITH SPEED" : differ ? "differ by less than 1 %" : "agree", view.chi2[m],
                view.dof[m],
                adequacy::Chi2Quantile999(static_cast<size_t>(view.dof[m])),
                view.speed_dependent[m] ? ": an effect whose gain depends on speed is missing (a tyre, compliance or aero "
                                          "term the model lacks, or a speed signal with a scale error)"
                                        : "");
  }
}

std::string GainViewCsv(const GainView& view, const std::vector<FittedModel>& models, const char* output, bool header) {
  std::string csv = header ? "output,band_mps,model,n,clusters,gain,se,judged,flagged\n" : "";
  for (size_t m = 0; m < view.per_model.size() && m < models.size(); ++m) {
    for (const GainBand& g : view.per_model[m]) {
      csv += Fmt("%s,%s,%s,%zu,%d,%.6g,%.6g,%d,%d\n", output, g.label.c_str(), models[m].label.c_str(), g.n, g.clusters,
                 g.gain, g.se, g.judged ? 1 : 0, g.flagged ? 1 : 0);
    }
  }
  return csv;
}

std::string GainViewJson(const GainView& view, const std::vector<FittedModel>& models) {
  nlohmann::json j = nlohmann::json::array();
  for (size_t m = 0; m < view.per_model.size() && m < models.size(); ++m) {
    nlohmann::json bands = nlohmann::json::array();
    for (const GainBand& g : view.per_model[m]) {
      bands.push_back({{"band_mps", g.label}, {"n", g.n}, {"clusters", g.clusters},
                       {"gain", std::isfinite(g.gain) ? nlohmann::json(g.gain) : nlohmann::json()},
                       {"se", std::isfinite(g.se) ? nlohmann::json(g.se) : nlohmann::json()}, {"judged", g.judged},
                       {"flagged", g.flagged}});
    }
    j.push_back({{"model", models[m].label}, {"bands", bands}, {"chi2", view.chi2[m]}, {"dof", view.dof[m]},
                 {"speed_dependent", view.speed_dependent[m]}});
  }
  return j.dump();
}

std::string GainViewHtml(const GainView& view, const std::vector<FittedModel>& models, const char* output) {
  std::string h = std::string("<h3>Signed, by speed: gain error of the ") + output +
                  " residual on the modelled output</h3>\n<p>Per 5 m/s band, e = c + k·y<sub>model</sub>: k in %, ± its "
                  "standard error clustered by chunk; flagged (red) when |k| &gt; " + Fmt("%g", kGainZ) + " SE and &gt; " +
                  Fmt("%g", 100 * kGainMin) + " %; grey: fewer than " + std::to_string(kGainMinChunks) +
                  " chunks, not judged. A gain error cancels in the bias columns above; a k that changes with "
                  "speed is the signature of an effect whose gain depends on speed.</p>\n<table><tr><th class=l>v [m/s]</th>";
  for (const auto& m : models) h += "<th>" + m.label + " k [%]</th><th>SE [%]</th><th>n</th>";
  h += "</tr>\n";
  for (size_t b = 0; !view.per_model.empty() && b < view.per_model[0].size(); ++b) {
    h += "<tr><td class=l>" + view.per_model[0][b].label + "</td>";
    for (const auto& bands : view.per_model) {
      const GainBand& g = bands[b];
      const std::string cls = g.flagged ? " class=fail" : (g.judged ? "" : " class=few");
      h += "<td" + cls + ">" + (std::isfinite(g.gain) ? Fmt("%+.2f", 100 * g.gain) : std::string("too few")) + "</td><td>" +
           (std::isfinite(g.se) ? Fmt("%.2f", 100 * g.se) : std::string()) + "</td><td>" + std::to_string(g.n) + "</td>";
    }
    h += "</tr>\n";
  }
  h += "</table>\n<p>";
  for (size_t m = 0; m < models.size() && m < view.chi2.size(); ++m) {
    if (view.dof[m] < 1) continue;
    h += models[m].label + ": the bands' gains " + (view.speed_dependent[m] ? "<b>change with speed</b>" : "agree") +
         " (chi² " + Fmt("%.1f", view.chi2[m]) + " on " + std::to_string(view.dof[m]) + " dof, 0.999 quantile " +
         Fmt("%.1f", adequacy::Chi2Quantile999(static_cast<size_t>(view.dof[m]))) + "). ";
  }
  return h + "</p>\n";
}

}  // namespace ndsid::desk
