// The live monitor (ndsidd's monitor channel) predicts with the current model, effects included
// (not the base model alone, which would ignore the learned effects). Synthetic segments
// whose truth has a steering offset: the monitor with the full model follows the measured a_y to
// the noise; with the base parameters alone it is off by the offset's effect.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "../identify/synthetic_segments.h"
#include "daemon_monitor.h"

namespace ndsid::service {
namespace {

struct Rms {
  double sum = 0;
  int n = 0;
  double value() const { return n ? std::sqrt(sum / n) : NAN; }
};

// Feeds the segments sample by sample as gated samples at 50 Hz; RMS of measured - modelled a_y
// over the messages that carry a model value.
Rms Feed(ModelMonitor& mon, const std::vector<stats::Segment>& segments) {
  Rms rms;
  int64_t t = 1'000'000'000;
  for (size_t si = 0; si < segments.size(); ++si) {
    const auto& seg = segments[si];
    for (size_t k = 0; k < seg.samples.size(); ++k) {
      gate::GatedSample g;
      g.sample.t_ns = t;
      g.sample.steer_rad = seg.samples[k].steer_rad;
      g.sample.speed_mps = seg.samples[k].speed_mps;
      g.sample.lat_accel_mps2 = seg.samples[k].lat_accel_mps2;
      g.sample.valid = true;
      g.verdict = gate::Verdict::kAccepted;
      g.drive_id = 0;
      g.segment_start = k == 0;
      t += 20'000'000;
      auto m = mon.Observe(g);
      if (m) mon.FillModel(*m);
      if (m && m->model_valid) {
        const double e = m->lat_accel_mps2 - m->lat_accel_model_mps2;
        rms.sum += e * e;
        ++rms.n;
      }
    }
    t += 5'000'000'000;  // a gap between segments
  }
  return rms;
}

TEST(ModelMonitor, PredictsWithTheModelsEffects) {
  const model::ModelSpec spec = model::ModelSpec::FromNames({"steer_offset"});
  const model::Params<double> base = ndsid::testing::TruthParams();
  for (const double offset_deg : {1.5, -0.8}) {
    std::vector<double> truth{base.m, base.Jz, base.cv, base.ch, base.lv, base.is, offset_deg * M_PI / 180};
    const auto segments = ndsid::testing::SyntheticSegmentsWithEffects(spec, truth, 4, 60, 0.05, 77);
    ModelMonitor plain(ndsid::testing::kWheelbase, 50, 10);
    plain.SetParams(base);
    const Rms without = Feed(plain, segments);
    ModelMonitor full(ndsid::testing::kWheelbase, 50, 10);
    full.SetParams(base);
    full.SetModel(std::make_shared<identify::Identifier>(ndsid::testing::DefaultIdentificationConfig(), ndsid::testing::kWheelbase, spec),
                  truth);
    const Rms with = Feed(full, segments);
    std::printf("steering offset %+.1f deg: monitor RMS with the effect %.4f m/s^2 over %d, base model only %.4f over %d\n",
                offset_deg, with.value(), with.n, without.value(), without.n);
    EXPECT_GT(with.n, 4 * 50);   // 4 x (60 s - the burn-in) at 10 Hz, most of it
    EXPECT_LT(with.value(), 0.06) << "the noise is 0.05 m/s^2";
    EXPECT_GT(without.value(), 1.5 * with.value()) << "the base model misses the offset";
  }
}

// Catches: a model without effects routed through the window re-simulation (it must stay the
// exact per-sample linear model).
TEST(ModelMonitor, ModelWithoutEffectsKeepsTheLinearPath) {
  const model::Params<double> base = ndsid::testing::TruthParams();
  const auto segments = ndsid::testing::SyntheticSegmentsWithEffects(model::ModelSpec(), {base.m, base.Jz, base.cv, base.ch, base.lv, base.is},
                                                                     2, 30, 0.05, 78);
  ModelMonitor a(ndsid::testing::kWheelbase, 50, 10), b(ndsid::testing::kWheelbase, 50, 10);
  a.SetParams(base);
  b.SetParams(base);
  b.SetModel(std::make_shared<identify::Identifier>(ndsid::testing::DefaultIdentificationConfig(), ndsid::testing::kWheelbase,
                                                    model::ModelSpec()),
             {base.m, base.Jz, base.cv, base.ch, base.lv, base.is});
  const Rms ra = Feed(a, segments), rb = Feed(b, segments);
  EXPECT_EQ(ra.n, rb.n);
  EXPECT_DOUBLE_EQ(ra.value(), rb.value());
}

}  // namespace
}  // namespace ndsid::service
