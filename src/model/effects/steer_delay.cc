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
      : EffectImpl({"steer_delay", "d_sw,true(t) = d_sw,meas(t + dt)", "correlates with steering rate at all speeds",
                    {{"steer_delay_s", "s", -0.1, 0.3, 0.0, 0.0, 0.08}}, 0}) {}
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
