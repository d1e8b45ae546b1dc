#include "ndsid/stats/coverage.h"

#include <algorithm>
#include <cmath>

#include "ndsid/common/error.h"

namespace ndsid::stats {

Histogram2d::Histogram2d(double x0, double x1, int nx_, double y0, double y1, int ny_)
    : x_min(x0), x_max(x1), y_min(y0), y_max(y1), nx(nx_), ny(ny_), counts(static_cast<size_t>(nx_ * ny_), 0.0) {}

void Histogram2d::Add(double x, double y, double w) noexcept {
  if (!std::isfinite(x) || !std::isfinite(y) || counts.empty()) return;
  // Clamp before the cast: a double beyond int's range converts with undefined behaviour
  // (on x86 to INT_MIN, which sent huge positive values to the first bin).
  const int ix = static_cast<int>(std::clamp(std::floor((x - x_min) / (x_max - x_min) * nx), 0.0, nx - 1.0));
  const int iy = static_cast<int>(std::clamp(std::floor((y - y_min) / (y_max - y_min) * ny), 0.0, ny - 1.0));
  counts[static_cast<size_t>(ix * ny + iy)] += w;
}

double Histogram2d::total() const {
  double t = 0;
  for (double c : counts) t += c;
  return t;
}

void Histogram2d::Merge(const Histogram2d& o) {
  if (o.counts.size() != counts.size()) throw Error("histogram shapes differ");
  for (size_t i = 0; i < counts.size(); ++i) counts[i] += o.counts[i];
}

double KlDivergence(const Histogram2d& p, const Histogram2d& q, double prior_samples) {
  if (p.counts.size() != q.counts.size() || p.counts.empty()) return 0.0;
  const double k = static_cast<double>(p.counts.size());
  const double alpha = prior_samples / k;
  const double tp = p.total() + alpha * k, tq = q.total() + alpha * k;
  double kl = 0;
  for (size_t i = 0; i < p.counts.size(); ++i) {
    const double pi = (p.counts[i] + alpha) / tp, qi = (q.counts[i] + alpha) / tq;
    kl += pi * std::log(pi / qi);
  }
  return kl;
}

Coverage::Coverage() : gg_(-10, 10, 40, -10, 10, 40), v_ay_(0, 50, 20, -10, 10, 40) {}

void Coverage::Add(const gate::GatedSample& g) noexcept {
  if (g.verdict != gate::Verdict::kAccepted) return;
  const auto& s = g.sample;
  gg_.Add(s.has_long_accel ? s.long_accel_mps2 : 0.0, s.lat_accel_mps2);
  v_ay_.Add(s.speed_mps, s.lat_accel_mps2);
}

void Coverage::Merge(const Coverage& o) {
  gg_.Merge(o.gg_);
  v_ay_.Merge(o.v_ay_);
}

double Coverage::ShareBelow(double limit) const {
  double below = 0, all = 0;
  for (int ix = 0; ix < v_ay_.nx; ++ix) {
    for (int iy = 0; iy < v_ay_.ny; ++iy) {
      const double c = v_ay_.counts[static_cast<size_t>(ix * v_ay_.ny + iy)];
      const double y_lo = v_ay_.y_min + (v_ay_.y_max - v_ay_.y_min) * iy / v_ay_.ny;
      const double y_hi = y_lo + (v_ay_.y_max - v_ay_.y_min) / v_ay_.ny;
      all += c;
      if (std::max(std::abs(y_lo), std::abs(y_hi)) <= limit + 1e-12) below += c;
    }
  }
  return all > 0 ? below / all : 0.0;
}

namespace {

// Counts of whole samples as integers (one to five bytes each in CBOR instead of a float's five
// or nine: most bins are 0), weighted ones as they are; both read back exactly.
nlohmann::json CountsJson(const std::vector<double>& counts) {
  nlohmann::json a = nlohmann::json::array();
  for (double c : counts) {
    if (c >= 0 && c < 9007199254740992.0 && c == std::floor(c)) {
      a.push_back(static_cast<uint64_t>(c));
    } else {
      a.push_back(c);
    }
  }
  return a;
}

}  // namespace

nlohmann::json Coverage::ToJson() const { return {{"gg", CountsJson(gg_.counts)}, {"v_ay", CountsJson(v_ay_.counts)}}; }

Coverage Coverage::FromJson(const JsonIn& in) {
  Coverage c;
  for (auto [key, h] : {std::pair{"gg", &c.gg_}, std::pair{"v_ay", &c.v_ay_}}) {
    const JsonIn counts = in.At(key);
    if (counts.Size(h->counts.size()) != h->counts.size())
      counts.Fail("needs " + std::to_string(h->counts.size()) + " bin counts");
    for (size_t i = 0; i < h->counts.size(); ++i) {
      const double v = counts.At(i).Finite();
      if (v < 0) counts.At(i).Fail("negative bin count");
      h->counts[i] = v;
    }
  }
  return c;
}

}  // namespace ndsid::stats
