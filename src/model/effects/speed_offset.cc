// Speed signal offset: v_meas = v + c (a calibration or dead-band error of the speed signal),
// v_true = v_meas - c. Signature: in the Ackermann term at low speed (the share c/v of the speed
// falls with v); with the yaw rate as a second output, a_y - v_meas r_meas leaves -c r, odd in
// the turn and independent of speed, so c is identified there (docs/two-outputs.md). A scale
// error of the speed (tyre radius) is speed_scale; this one is the constant part.
// The kinematic bank estimate lowpass(v_meas r_meas - a_y) that initialises road_bank's state
// read the raw speed: corrected by c r_meas at the stretch's first sample.
// From a_y alone c trades with is and speed_scale (all act through the Ackermann term), so it is
// a default candidate of the diagnosis only with the yaw rate as an output. The corrected speed
// is held at >= 1 m/s (the model is singular at v -> 0; the gate's min_speed_mps is 5 by default).
#include "builtin_effects.h"

namespace ndsid::model {
namespace {

constexpr double kMinSpeed_mps = 1.0;

class SpeedOffset final : public EffectImpl<SpeedOffset> {
 public:
  SpeedOffset()
      : EffectImpl({.name = "speed_offset",
                    .description = "v_true = v_meas - c (speed signal offset)",
                    .signature = "Ackermann term at low speed; with the yaw rate: -c r in a_y - v_meas r_meas",
                    .params = {{.name = "speed_offset_mps", .unit = "m/s",
                                .lower = -3.0, .upper = 3.0, .initial = 0.0, .neutral = 0.0, .typical = 0.5}},
                    .num_states = 0,
                    .needs_yaw_rate_output = true}) {}
  template <class T>
  void InputsT(const T* eta, const InputSeries&, size_t, ModelInputs<T>& u) const {
    u.speed_mps -= eta[0];
    if (ScalarOf(u.speed_mps) < kMinSpeed_mps) u.speed_mps = T(kMinSpeed_mps);
    if (u.yaw_rate_measured) u.bank_mps2 -= eta[0] * u.yaw_rate_meas_radps;
  }
};

}  // namespace

std::shared_ptr<const Effect> MakeSpeedOffset() { return std::make_shared<SpeedOffset>(); }

}  // namespace ndsid::model
