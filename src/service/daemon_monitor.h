// The monitor stream: the current parameters simulated alongside the data on the reading path
// (linear single-track model, ndsid::model::Rk4Step at the sync rate, reset to its steady state
// at every gated segment start), decimated to lcm.monitor_rate_hz.
// With model effects (SetModel) the monitor predicts with the current model, effects included:
// at every message it re-simulates the last kWindow_s of the gated segment exactly as the fit
// scores it (identify::SimulateChunks: the identification rate, the road-bank estimate, the
// burn-in) and reports the newest sample; no model value until the window is past the burn-in.
// Thread: the reading thread (called with every gated sample).
#pragma once

#include <memory>
#include <optional>
#include <vector>

#include "ndsid/gate/gate.h"
#include "ndsid/identify/identifier.h"
#include "ndsid/stats/segment.h"
#include "ndsid/model/single_track.h"
#include "ndsid/publish/estimate_sink.h"

namespace ndsid::service {

class ModelMonitor {
 public:
  ModelMonitor(double wheelbase_m, double sync_rate_hz, double monitor_rate_hz);

  // Parameters to simulate (a new valid estimate); empty: no model yet.
  void SetParams(const std::optional<model::Params<double>>& params);
  // The full model (effects included) and its full parameter vector: the monitor then predicts
  // with it (a model without effects: nullptr, SetParams' linear model is used).
  void SetModel(std::shared_ptr<const identify::Identifier> model, std::vector<double> params);
  static constexpr double kWindow_s = 10.0;

  // Steps the model with this sample; returns a message every decimation-th sample. With a
  // model with effects the message's model values are filled by FillModel (the re-simulation
  // is paid only for messages that are sent: the wall-clock limit drops most in a fast replay).
  std::optional<publish::MonitorMessage> Observe(const gate::GatedSample& g) noexcept;
  void FillModel(publish::MonitorMessage& m) noexcept;

 private:
  double wheelbase_m_;
  double period_s_;
  int decimation_;
  int count_ = 0;
  std::optional<model::Params<double>> params_;
  bool running_ = false;  // model state valid (inside a gated segment)
  model::State<double> x_{0, 0};
  double prev_steer_ = 0, prev_speed_ = 0;
  int64_t prev_t_ns_ = 0;
  // The model with effects, and the recent gated samples at the identification rate.
  bool EffectsModelOutput(double& a_y, double& r) noexcept;
  std::shared_ptr<const identify::Identifier> model_;
  std::vector<double> model_params_;
  stats::Segment window_;
  int window_decimation_ = 1;
  int window_count_ = 0;
  bool window_running_ = false;
  bool pending_model_ = false;  // the last message may get the effects model's values
};

}  // namespace ndsid::service
