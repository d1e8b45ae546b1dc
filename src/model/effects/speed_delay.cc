// Speed signal latency: the speed message carries the speed from tau earlier than the
// accelerometer's time, v_true(t) = v_meas(t + tau) (linear interpolation between samples,
// differentiable in tau). Signature: correlates with the longitudinal acceleration times the
// speed's share of a_y (through v^2 in the Ackermann term and v in the yaw rate): weak, it needs
// hours of braking and accelerating in curves. Step 0 of the diagnosis estimates the same
// latency jointly with the model (this effect) and removes it in the sync stage
// (signals.vehicle_speed.latency_s); the effect is the choice where it should stay in the model.
#include "builtin_effects.h"

namespace ndsid::model {
namespace {

class SpeedDelay final : public EffectImpl<SpeedDelay> {
 public:
  SpeedDelay()
      : EffectImpl({.name = "speed_delay",
                    .description = "v_true(t) = v_meas(t + tau) (speed signal latency)",
                    .signature = "~ a_x times the speed's share of a_y and r; weak",
                    .params = {{.name = "speed_delay_s", .unit = "s",
                                .lower = -0.2, .upper = 0.6, .initial = 0.0, .neutral = 0.0, .typical = 0.15}},
                    .num_states = 0,
                    .default_candidate = false}) {}
  template <class T>
  void InputsT(const T* eta, const InputSeries& s, size_t k, ModelInputs<T>& u) const {
    // Added as the change the shift makes, so that speed_offset's and speed_scale's corrections
    // (applied after this in the table) and the bank estimate stay as they are.
    u.speed_mps += s.Speed(T(static_cast<double>(k)) + eta[0] / T(s.dt_s)) - T(s.speed(k));
  }
};

}  // namespace

std::shared_ptr<const Effect> MakeSpeedDelay() { return std::make_shared<SpeedDelay>(); }

}  // namespace ndsid::model
