// Signal time skew: the steering message arrives dt later than the accelerometer's, so the
// measured steering at t is the true steering at t - dt: d_sw,true(t) = d_sw,meas(t + dt)
// (linear interpolation between samples, differentiable in dt). Signature: correlates with
// the steering rate at all speeds.
#include "builtin_effects.h"

namespace ndsid::model {
namespace {

class SteerDelay final : public EffectImpl<SteerDelay> {
 public:
  SteerDelay()
      : EffectImpl({.name = "steer_delay",
                    .description = "d_sw,true(t) = d_sw,meas(t + dt)",
                    .signature = "correlates with steering rate at all speeds",
                    .params = {{.name = "steer_delay_s", .unit = "s",
                                .lower = -0.1, .upper = 0.3, .initial = 0.0, .neutral = 0.0, .typical = 0.08}},
                    .num_states = 0}) {}
  template <class T>
  void InputsT(const T* eta, const InputSeries& s, size_t k, ModelInputs<T>& u) const {
    // Keep the speed as is; shift only the steering (fractional sample index). Added as the
    // change the shift makes, so that earlier input effects (steer_offset) are kept.
    u.steer_rad += s.Steer(T(static_cast<double>(k)) + eta[0] / T(s.dt_s)) - T(s.steer(k));
  }
};

}  // namespace

std::shared_ptr<const Effect> MakeSteerDelay() { return std::make_shared<SteerDelay>(); }

}  // namespace ndsid::model
