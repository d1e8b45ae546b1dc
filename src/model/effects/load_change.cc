// Mass / load change between drives (physics.md §4): drive d carries m and Jz scaled by its
// load ratio rho_d (passengers, luggage, fuel; Jz alike), i.e. the tyre forces divided by
// rho_d. Per drive, relative to the reference drive: a common factor on every drive is exactly
// cv and ch scaled by its inverse, so the reference drive keeps rho = 1 and the parameters and
// EG describe its load. Signature: EG drifts between drives; within one drive a load is EG
// itself.
#include "builtin_effects.h"

namespace ndsid::model {
namespace {

class LoadChange final : public EffectImpl<LoadChange> {
 public:
  LoadChange()
      : EffectImpl({.name = "load_change",
                    .description = "m and Jz of each drive scaled by its load ratio rho: tyre forces / rho",
                    .signature = "per drive: EG (and cv/m, ch/m) differ between drives",
                    .params = {{.name = "load_ratio", .unit = "-",
                                .lower = 0.5, .upper = 2.0, .initial = 1.0, .neutral = 1.0, .typical = 1.15,
                                .per_drive = true,
                                .common_mode = {{kStiffFront, -1.0}, {kStiffRear, -1.0}}}},
                    .num_states = 0}) {}
  template <class T>
  void ForcesT(const T* eta, const Params<T>&, double, const AxleSlip<T>&, const State<T>&, const ModelInputs<T>&,
               const T*, ForceTerms<T>& f) const {
    f.force_front_n /= eta[0];
    f.force_rear_n /= eta[0];
  }
};

}  // namespace

std::shared_ptr<const Effect> MakeLoadChange() { return std::make_shared<LoadChange>(); }

}  // namespace ndsid::model
