#include "ndsid/identify/linearized_window.h"

#include <cmath>

#include "ndsid/identify/chunks.h"

namespace ndsid::identify {
namespace {

constexpr size_t kMaxParams = 64;        // far above any model's parameter count
constexpr size_t kMaxSegments = 1'000'000;
constexpr size_t kMaxChunksPerSegment = 1'000'000;

nlohmann::json Binary(const std::vector<double>& v) { return DoublesToBinary(v.data(), v.size()); }

std::vector<double> FiniteDoubles(const JsonIn& in, size_t count) {
  std::vector<double> v = in.Doubles(count);
  for (size_t i = 0; i < v.size(); ++i) {
    if (!std::isfinite(v[i])) in.Fail("value " + std::to_string(i) + " is not finite");
  }
  return v;
}

// A J'J (np x np, row-major): finite, with a non-negative diagonal.
std::vector<double> GramMatrix(const JsonIn& in, size_t np) {
  std::vector<double> v = FiniteDoubles(in, np * np);
  for (size_t a = 0; a < np; ++a) {
    if (v[a * np + a] < 0) in.Fail("a negative diagonal element: not a J'J");
  }
  return v;
}

std::vector<double> Acf(const JsonIn& in, uint32_t n) {
  if (n == 0) return {};
  std::vector<double> v = FiniteDoubles(in, kAcfMaxLag + 1);
  if (v[0] < 0) in.Fail("a negative sum of squares");
  return v;
}

// A list of segments' chunks. held_out: the held-out segments' (no autocorrelation sums).
nlohmann::json SegmentsToJson(const std::vector<LinearizedSegment>& segments, bool held_out) {
  nlohmann::json segs = nlohmann::json::array();
  for (const LinearizedSegment& s : segments) {
    nlohmann::json js;
    js["drive_id"] = s.drive_id;
    js["t0_ns"] = s.t0_ns;
    js["samples"] = s.samples;
    nlohmann::json chunks = nlohmann::json::array();
    for (const LinearizedChunk& c : s.chunks) {
      nlohmann::json jc;
      jc["theta"] = Binary(c.theta);
      jc["jtj"] = Binary(c.jtj);
      jc["score"] = Binary(c.score);
      jc["rss"] = c.rss;
      jc["rss_a_y"] = c.rss_a_y;
      jc["rss_yaw_rate"] = c.rss_yaw_rate;
      jc["n_a_y"] = c.n_a_y;
      jc["n_yaw_rate"] = c.n_yaw_rate;
      if (!held_out) {
        jc["acf_a_y"] = Binary(c.acf_a_y);
        jc["acf_yaw_rate"] = Binary(c.acf_yaw_rate);
      }
      if (!c.jtj_yaw_rate.empty()) {
        jc["jtj_yaw_rate"] = Binary(c.jtj_yaw_rate);
        jc["score_yaw_rate"] = Binary(c.score_yaw_rate);
      }
      chunks.push_back(std::move(jc));
    }
    js["chunks"] = std::move(chunks);
    segs.push_back(std::move(js));
  }
  return segs;
}

std::vector<LinearizedSegment> SegmentsFromJson(const JsonIn& segs, size_t np, bool held_out) {
  std::vector<LinearizedSegment> out;
  const size_t ns = segs.Size(kMaxSegments);
  out.reserve(ns);
  for (size_t i = 0; i < ns; ++i) {
    const JsonIn js = segs.At(i);
    LinearizedSegment s;
    s.drive_id = js.Int64("drive_id");
    s.t0_ns = js.Int64("t0_ns");
    s.samples = js.UInt64("samples");
    const JsonIn chunks = js.At("chunks");
    const size_t nc = chunks.Size(kMaxChunksPerSegment);
    s.chunks.reserve(nc);
    for (size_t k = 0; k < nc; ++k) {
      const JsonIn jc = chunks.At(k);
      LinearizedChunk c;
      c.theta = FiniteDoubles(jc.At("theta"), np);
      c.jtj = GramMatrix(jc.At("jtj"), np);
      c.score = FiniteDoubles(jc.At("score"), np);
      c.rss = jc.Finite("rss");
      c.rss_a_y = jc.Finite("rss_a_y");
      c.rss_yaw_rate = jc.Finite("rss_yaw_rate");
      if (c.rss < 0 || c.rss_a_y < 0 || c.rss_yaw_rate < 0) jc.At("rss").Fail("a negative sum of squares");
      const uint64_t na = jc.UInt64("n_a_y"), nr = jc.UInt64("n_yaw_rate");
      if (na == 0 || na > UINT32_MAX || nr > UINT32_MAX) jc.At("n_a_y").Fail("residual counts out of range");
      c.n_a_y = static_cast<uint32_t>(na);
      c.n_yaw_rate = static_cast<uint32_t>(nr);
      if (!held_out) {
        c.acf_a_y = Acf(jc.At("acf_a_y"), c.n_a_y);
        c.acf_yaw_rate = Acf(jc.At("acf_yaw_rate"), c.n_yaw_rate);
      }
      // Optional (states written before they were kept have neither): both or none.
      if (jc.Has("jtj_yaw_rate") || jc.Has("score_yaw_rate")) {
        c.jtj_yaw_rate = GramMatrix(jc.At("jtj_yaw_rate"), np);
        c.score_yaw_rate = FiniteDoubles(jc.At("score_yaw_rate"), np);
      }
      s.chunks.push_back(std::move(c));
    }
    out.push_back(std::move(s));
  }
  return out;
}

}  // namespace

size_t LinearizedWindow::chunks() const {
  size_t n = 0;
  for (const LinearizedSegment& s : segments) n += s.chunks.size();
  return n;
}

bool LinearizedWindow::Compatible(const std::string& model_description, const std::vector<double>& scale_now,
                                  double chunk_s_now, double burn_in_s_now) const {
  if (model != model_description || scale != scale_now || chunk_s != chunk_s_now || burn_in_s != burn_in_s_now) {
    return false;
  }
  const size_t np = scale.size();
  for (const auto* list : {&segments, &held_out}) {
    for (const LinearizedSegment& s : *list) {
      for (const LinearizedChunk& c : s.chunks) {
        if (c.theta.size() != np || c.score.size() != np || c.jtj.size() != np * np) return false;
        if (!c.jtj_yaw_rate.empty() && (c.jtj_yaw_rate.size() != np * np || c.score_yaw_rate.size() != np)) return false;
      }
    }
  }
  return true;
}

bool LinearizedWindow::Reweightable() const {
  if (!(weight_a_y > 0) || !(weight_yaw_rate > 0)) return false;
  const size_t np = scale.size();
  for (const LinearizedSegment& s : segments) {
    for (const LinearizedChunk& c : s.chunks) {
      if (c.jtj_yaw_rate.size() != np * np || c.score_yaw_rate.size() != np) return false;
    }
  }
  return true;
}

LinearizedWindow LinearizedWindow::Reweighted(double weight_a_y_now, double weight_yaw_rate_now) const {
  LinearizedWindow w = *this;
  const double fa = (weight_a_y_now / weight_a_y) * (weight_a_y_now / weight_a_y);
  const double fr = (weight_yaw_rate_now / weight_yaw_rate) * (weight_yaw_rate_now / weight_yaw_rate);
  auto mix = [&](std::vector<double>& total, std::vector<double>& yaw) {
    for (size_t i = 0; i < total.size(); ++i) {
      const double y = yaw[i];
      total[i] = fa * (total[i] - y) + fr * y;
      yaw[i] = fr * y;
    }
  };
  for (LinearizedSegment& s : w.segments) {
    for (LinearizedChunk& c : s.chunks) {
      mix(c.jtj, c.jtj_yaw_rate);
      mix(c.score, c.score_yaw_rate);
      c.rss = weight_a_y_now * weight_a_y_now * c.rss_a_y + weight_yaw_rate_now * weight_yaw_rate_now * c.rss_yaw_rate;
      for (double& x : c.acf_a_y) x *= fa;
      for (double& x : c.acf_yaw_rate) x *= fr;
    }
  }
  w.weight_a_y = weight_a_y_now;
  w.weight_yaw_rate = weight_yaw_rate_now;
  return w;
}

nlohmann::json LinearizedWindow::ToJson() const {
  nlohmann::json j;
  j["model"] = model;
  j["scale"] = scale;
  j["weight_a_y"] = weight_a_y;
  j["weight_yaw_rate"] = weight_yaw_rate;
  j["chunk_s"] = chunk_s;
  j["burn_in_s"] = burn_in_s;
  j["updates_since_full"] = updates_since_full;
  j["segments"] = SegmentsToJson(segments, false);
  if (!held_out.empty()) j["held_out"] = SegmentsToJson(held_out, true);
  return j;
}

LinearizedWindow LinearizedWindow::FromJson(const JsonIn& in) {
  LinearizedWindow w;
  w.model = in.String("model");
  w.scale = in.At("scale").Numbers(kMaxParams);
  for (size_t i = 0; i < w.scale.size(); ++i) {
    if (!std::isfinite(w.scale[i]) || w.scale[i] == 0) in.At("scale").At(i).Fail("not a finite non-zero scale");
  }
  const size_t np = w.scale.size();
  w.weight_a_y = in.Finite("weight_a_y");
  w.weight_yaw_rate = in.Finite("weight_yaw_rate");
  if (!(w.weight_a_y > 0) || w.weight_yaw_rate < 0) in.At("weight_a_y").Fail("output weights must be positive");
  w.chunk_s = in.Finite("chunk_s");
  w.burn_in_s = in.Finite("burn_in_s");
  const int64_t updates = in.Int64("updates_since_full");
  if (updates < 0 || updates > 1'000'000'000) in.At("updates_since_full").Fail("out of range");
  w.updates_since_full = static_cast<int>(updates);
  w.segments = SegmentsFromJson(in.At("segments"), np, false);
  if (in.Has("held_out")) w.held_out = SegmentsFromJson(in.At("held_out"), np, true);
  return w;
}

}  // namespace ndsid::identify
