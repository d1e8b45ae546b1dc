// Identification benchmark: wall time and peak memory of one windowed re-identification over
// H gated hours of simulated naturalistic driving (the daemon's periodic job).
//   ndsid_bench_identify_window HOURS [EFFECTS...]
// The drives are streamed from the simulator straight into the gate and the window (no CAN
// round trip: that path has its own benchmark); the window is then identified once.
#include <sys/resource.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "ndsid/config/config.h"
#include "ndsid/config/simulation_config.h"
#include "ndsid/gate/gate.h"
#include "ndsid/identify/identifier.h"
#include "ndsid/sim/simulator.h"
#include "ndsid/stats/accumulator.h"

namespace {

long PeakRssKb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s GATED_HOURS [--no-coarse-start] [EFFECT...]\n", argv[0]);
    return 2;
  }
  const double want_h = std::atof(argv[1]);
  int first_effect = 2;
  const bool coarse = !(argc > 2 && std::string(argv[2]) == "--no-coarse-start");
  if (!coarse) ++first_effect;
  std::vector<std::string> effects(argv + first_effect, argv + argc);
  ndsid::config::Config cfg = ndsid::config::LoadConfig(std::string(NDSID_SOURCE_DIR) + "/config/example_vehicle.yaml");
  cfg.identification.window_h = want_h;
  if (!coarse) cfg.identification.coarse_min_chunks = 0;
  cfg.model_effects = effects;
  ndsid::config::SimulationConfig sim;
  sim.seed = 7;
  sim.duration.hours = want_h * 1.6;  // ~60 % of driving time passes the gate
  ndsid::gate::Gate gate(cfg.gate, 0.01);
  ndsid::stats::Accumulator acc(cfg, 100.0);
  const auto t0 = std::chrono::steady_clock::now();
  int64_t offset_ns = 0;
  ndsid::sim::SimulateDrives(sim, [&](ndsid::sim::DriveResult&& d) {
    const auto& s = d.series;
    for (size_t i = 0; i < s.t_s.size(); ++i) {
      ndsid::sync::Sample x;
      x.t_ns = d.start_epoch_ns + static_cast<int64_t>(s.t_s[i] * 1e9) + offset_ns;
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
    }
  });
  acc.Finish();
  const double sim_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ndsid::identify::SegmentList segs;
  for (const auto& s : acc.window()) segs.push_back(s.get());
  const long rss_before = PeakRssKb();
  const ndsid::identify::Identifier id(cfg.identification, cfg.vehicle.wheelbase_m,
                                       ndsid::model::ModelSpec::FromNames(effects));
  const auto t1 = std::chrono::steady_clock::now();
  const auto r = id.Identify(segs, {}, std::optional<std::vector<double>>{});
  const double fit_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
  std::vector<double> truth = {sim.vehicle.mass_kg, sim.vehicle.yaw_inertia_kgm2, sim.vehicle.cornering_stiffness_front_npr,
                               sim.vehicle.cornering_stiffness_rear_npr, sim.vehicle.cg_to_front_m, sim.vehicle.steering_ratio};
  for (int i = ndsid::model::kNumParams; i < id.spec().num_params(); ++i) {
    truth.push_back(id.spec().param_name(i) == "road_bank_gain" ? 1.0 : id.spec().effect_param(i)->neutral);
  }
  const double eg_truth = ndsid::model::EgToDegPerG(
      ndsid::model::SelfSteerGradient(ndsid::model::Params<double>::FromArray(truth.data()), sim.vehicle.wheelbase_m));
  std::printf("truth: EG %.4f deg/g, RMSE at the true parameters %.4f m/s^2 (fit: %.4f)\n", eg_truth,
              id.Rmse(truth, segs), r.rmse_train_mps2);
  for (const auto& p : r.effect_params) std::printf("  %s = %.4g ± %.2g %s\n", p.name.c_str(), p.value, p.se, p.unit.c_str());
  std::printf("window %.2f gated h (%zu segments, %zu residuals), model %s, outputs %s, threads %d: identification %.1f s "
              "(%d iterations after %d on the coarse start), peak RSS %.0f MB (%.0f MB before the fit); simulation+gating %.1f s; EG %.4f ± %.4f deg/g%s\n",
              acc.window_hours(), segs.size(), r.residuals_train, r.model.c_str(),
              r.yaw_rate_output ? "a_y + yaw rate" : "a_y", cfg.identification.threads, fit_s,
              r.iterations, r.coarse_iterations, PeakRssKb() / 1024.0, rss_before / 1024.0, sim_s, r.eg_deg_per_g, r.eg_se_deg_per_g,
              r.valid ? "" : (" NOT VALID: " + r.reason).c_str());
  return r.valid ? 0 : 1;
}
