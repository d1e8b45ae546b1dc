// The monitor stream: the current parameters simulated alongside the data on the reading path
// (linear single-track model, ndsid::model::Rk4Step at the sync rate, reset to its steady state
// at every gated segment start), decimated to lcm.monitor_rate_hz.
// Thread: the reading thread (called with every gated sample).
#pragma once

#include <optional>

#include "ndsid/gate/gate.h"
#include "ndsid/model/single_track.h"
#include "ndsid/publish/estimate_sink.h"

namespace ndsid::service {

class ModelMonitor {
 public:
  ModelMonitor(double wheelbase_m, double sync_rate_hz, double monitor_rate_hz);

  // Parameters to simulate (a new valid estimate); empty: no model yet.
  void SetParams(const std::optional<model::Params<double>>& params);

  // Steps the model with this sample; returns a message every decimation-th sample.
  std::optional<publish::MonitorMessage> Observe(const gate::GatedSample& g) noexcept;

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
};

}  // namespace ndsid::service
