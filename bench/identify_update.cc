// The cost of one periodic update at a given history (docs/incremental.md), incremental against
// the full-window refit, side by side in one process:
//   ndsid_bench_identify_update HOURS [EFFECTS...]
// Simulated drives (seed 7) stream through the gate into a window of HOURS; when the window
// holds HOURS - period_s of gated data, a full-window fit gives the prior; then, once the window
// holds HOURS, one incremental update on top of it and one full refit from the same warm start
// are timed. Prints both wall times, the chunks each simulated, and how far apart their EGs are.
// NDSID_HELD_OUT=1 holds out every k-th drive (k = 1 / identification.validation_fraction), as
// the pipeline does, so both fits also give the held-out RMSE (the incremental update from the
// held-out chunks' quadratics where it can: docs/incremental.md, "The held-out RMSE").
#include <spdlog/spdlog.h>
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "ndsid/config/config.h"
#include "ndsid/config/simulation_config.h"
#include "ndsid/gate/gate.h"
#include "ndsid/identify/identifier.h"
#include "ndsid/sim/simulator.h"
#include "ndsid/stats/accumulator.h"
#include "ndsid/stats/held_out.h"

namespace {

double Seconds(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s GATED_HOURS [EFFECT...]\n", argv[0]);
    return 2;
  }
  namespace id = ndsid::identify;
  const double want_h = std::atof(argv[1]);
  if (std::getenv("NDSID_DEBUG")) spdlog::set_level(spdlog::level::debug);
  std::vector<std::string> effects(argv + 2, argv + argc);
  ndsid::config::Config cfg = ndsid::config::LoadConfig(std::string(NDSID_SOURCE_DIR) + "/config/example_vehicle.yaml");
  cfg.identification.window_h = want_h;
  cfg.model_effects = effects;
  if (std::getenv("NDSID_AY_ONLY")) cfg.identification.yaw_rate_output = false;
  if (const char* c = std::getenv("NDSID_COARSE_MIN_CHUNKS")) cfg.identification.coarse_min_chunks = static_cast<size_t>(std::atol(c));
  const double prior_h = want_h - cfg.identification.period_s / 3600.0;
  ndsid::config::SimulationConfig sim;
  sim.seed = 7;
  sim.duration.hours = want_h * 1.7;  // ~60 % of driving time passes the gate
  ndsid::gate::Gate gate(cfg.gate, 0.01);
  ndsid::stats::Accumulator acc(cfg, 100.0);
  const id::Identifier identifier(cfg.identification, cfg.vehicle.wheelbase_m, ndsid::model::ModelSpec::FromNames(effects));
  // As Pipeline::Snapshot (stats/held_out.h): every k-th drive, or with none of those in the
  // window, the shortest drive once there are two.
  const double frac = std::getenv("NDSID_HELD_OUT") ? cfg.identification.validation_fraction : 0.0;
  auto split = [&] {  // (training, validation)
    std::pair<id::SegmentList, id::SegmentList> out;
    const std::set<int64_t> drives = ndsid::stats::HeldOutDrives(acc.window(), frac);
    for (const auto& s : acc.window()) (drives.count(s->drive_id) ? out.second : out.first).push_back(s.get());
    return out;
  };
  std::vector<std::shared_ptr<const ndsid::stats::Segment>> keep_prior;
  id::IdentificationResult prior_fit;
  double prior_s = 0;
  bool done = false;
  ndsid::sim::SimulateDrives(sim, [&](ndsid::sim::DriveResult&& d) {
    const auto& s = d.series;
    for (size_t i = 0; i < s.t_s.size() && !done; ++i) {
      ndsid::sync::Sample x;
      x.t_ns = d.start_epoch_ns + static_cast<int64_t>(s.t_s[i] * 1e9);
      x.steer_rad = s.steer_sw_meas_rad[i];
      x.speed_mps = s.speed_meas_mps[i];
      x.lat_accel_mps2 = s.a_y_meas_mps2[i];
      x.yaw_rate_radps = s.yaw_rate_meas_radps[i];
      x.long_accel_mps2 = s.a_x_meas_mps2[i];
      x.has_yaw_rate = x.has_long_accel = true;
      x.reverse = s.reverse[i] != 0;
      x.esc_active = s.esp_active[i] != 0;
      x.valid = s.valid[i] != 0;
      acc.Add(gate.Process(x));
      if (!prior_fit.linearized && acc.gated_hours() >= prior_h) {
        keep_prior.assign(acc.window().begin(), acc.window().end());
        const auto t0 = std::chrono::steady_clock::now();
        const auto [train, held] = split();
        prior_fit = identifier.Identify(train, held, std::nullopt, id::IncrementalUpdate{nullptr, 0.5, true});
        prior_s = Seconds(t0);
      }
      done = prior_fit.linearized && acc.gated_hours() >= want_h;
    }
  });
  acc.Finish();  // closes the open segment: the last data join the window
  if (!prior_fit.linearized) {
    std::fprintf(stderr, "the simulation gave no prior (%.2f gated h)\n", acc.gated_hours());
    return 1;
  }
  const auto [segs, val] = split();
  const double rc = cfg.identification.relinearize_sigma;
  const auto t1 = std::chrono::steady_clock::now();
  const auto inc = identifier.Identify(segs, val, prior_fit.AllValues(), id::IncrementalUpdate{prior_fit.linearized, rc, true});
  const double inc_s = Seconds(t1);
  const auto t2 = std::chrono::steady_clock::now();
  const auto full = identifier.Identify(segs, val, prior_fit.AllValues());
  const double full_s = Seconds(t2);
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  std::printf("history %.2f gated h (%zu chunks; prior at %.2f h, its full fit %.1f s): incremental update %.2f s "
              "(%zu chunks simulated, %zu from the prior, %d iterations), full refit %.2f s (%d iterations after %d coarse): "
              "ratio %.1fx; EG %.4f vs %.4f deg/g, %.3f sigma apart; peak RSS %.0f MB\n",
              acc.gated_hours(), full.chunks, prior_fit.train_hours, prior_s, inc_s, inc.chunks_simulated,
              inc.chunks_from_prior, inc.iterations, full_s, full.iterations, full.coarse_iterations, full_s / inc_s, inc.eg_deg_per_g,
              full.eg_deg_per_g, std::abs(inc.eg_rad_per_mps2 - full.eg_rad_per_mps2) / full.eg_se_rad_per_mps2,
              u.ru_maxrss / 1024.0);
  if (!val.empty()) {
    std::printf("  held out: %zu segments; incremental: %zu chunks from their quadratics, %zu simulated with their Jacobian; "
                "held-out RMSE a_y %.5f vs %.5f m/s^2 (full refit, simulated)\n",
                val.size(), inc.held_out_from_prior, inc.held_out_linearized, inc.rmse_validation_mps2, full.rmse_validation_mps2);
  }
  return inc.valid && full.valid ? 0 : 1;
}
