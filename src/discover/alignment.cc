// Step 0 (alignment.h): the roles' latencies in order (yaw rate, steering, speed, the steering
// again after the speed's), each found by latency_search.h, and whether each is applied.
#include "ndsid/discover/alignment.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "latency_search.h"
#include "ndsid/identify/chunks.h"

namespace ndsid::discover {
using namespace identify;  // the estimator this stage builds on
using config::Role;

std::vector<stats::Segment> AlignSegments(const SegmentList& segments, const std::vector<RoleLatency>& latencies) {
  return Shifted(segments, latencies, true);
}

std::vector<RoleLatency> EstimateRoleLatencies(const Identifier& two_or_one, const std::vector<double>& params,
                                               const SegmentList& training, const AlignmentOptions& options) {
  // The steering's and the speed's profiles score a_y (Identifier::Rmse); the steering's joint
  // refit uses the configured outputs. With two outputs the yaw rate is profiled too (below).
  const Identifier& identifier = two_or_one;
  const bool two = two_or_one.config().yaw_rate_output;
  std::vector<RoleLatency> out;
  const double dt = training.empty() ? 0.0 : training.front()->dt_s;
  const double floor_s = options.min_apply_s >= 0 ? options.min_apply_s : 0.5 * dt;
  auto decide = [&](RoleLatency& l) {
    const bool significant = std::abs(l.latency_s) > options.z_apply * l.se_s;
    l.apply = l.determined && significant && std::abs(l.latency_s) >= floor_s;
    if (l.determined && !significant) {
      l.note = "not significant";
    } else if (l.determined && !l.apply) {
      char buf[160];
      std::snprintf(buf, sizeof buf, "below the model's timing resolution (%.1f ms, half a sample of the fit)", 1e3 * floor_s);
      l.note = buf;
    }
  };
  // Two outputs: the yaw rate first (a gyro latency reaches a_y through the bank observer and
  // would pull the steering's shift), then steering and speed on a_y. When the first pass applies
  // nothing, the yaw rate is profiled again on the data aligned for the inputs (a steering skew
  // shifts the modelled yaw rate too) and that is its result (below).
  // The first pass is a joint refit of model and shift (gyro_delay) like the inputs': the fit on
  // the skewed data has absorbed part of a gyro latency (heavily weighted, the yaw rate bends the
  // parameters towards it), so a profile with them held found half of it (60 ms read as 32 ms),
  // and the steering's joint refit then took up the rest with the wrong sign (-27 ms) through
  // the yaw rate it models. A steering skew is fitted along (steer_delay, a nuisance here; the
  // steering's own step below finds it): both outputs see a steering skew, only the yaw rate a
  // gyro latency, so the joint refit splits the two (a 100 ms gyro latency with a 40 ms steering
  // skew read as 59 ms on the yaw rate and 1 ms on the steering without it). The speed's offset
  // too, as for the speed's latency below: without it a hidden -2 km/h offset read as a 46 ms
  // gyro latency and a 38 ms steering skew. The steering is searched with the joint refit's
  // parameters.
  SegmentList data = training;
  std::vector<stats::Segment> yaw_aligned;
  const std::vector<double>* now = &params;
  std::vector<double> yaw_refitted;
  RoleLatency yaw1;
  if (two) {
    yaw1 = JointLatency(two_or_one, params, training, Role::kYawRate, "gyro_delay", {"steer_delay", "speed_offset"}, options,
                        floor_s, yaw_refitted);
    decide(yaw1);
    spdlog::debug("alignment: yaw rate, first pass {:.1f} +- {:.1f} ms ({}){}", 1e3 * yaw1.latency_s, 1e3 * yaw1.se_s, yaw1.method,
                  yaw1.apply ? ", applied" : "");
    if (yaw1.apply) {
      yaw_aligned = AlignSegments(training, {yaw1});
      data = Pointers(yaw_aligned);
      if (yaw_refitted.size() == params.size()) now = &yaw_refitted;
    }
  }
  // The speed is searched on data aligned for the steering (with the joint fit's parameters):
  // a steering skew left in would pull the speed's shift.
  std::vector<double> refitted;
  out.push_back(JointLatency(identifier, *now, data, Role::kSteeringWheelAngle, "steer_delay", {}, options, floor_s, refitted));
  RoleLatency& steer = out.back();
  decide(steer);
  std::vector<stats::Segment> steer_aligned;
  if (steer.apply && refitted.size() == params.size()) {
    steer_aligned = AlignSegments(data, {steer});
    data = Pointers(steer_aligned);
    now = &refitted;
  }
  // With two outputs the speed's offset is fitted along: it is identified there (-c r in
  // a_y - v r_meas), and a speed latency alone takes up part of a hidden offset (-2 km/h read as
  // a -74 +- 17 ms latency). With a_y alone the offset is not identified and is left out.
  std::vector<double> speed_refitted;
  const std::vector<std::string> speed_nuisance = two ? std::vector<std::string>{"speed_offset"} : std::vector<std::string>{};
  out.push_back(JointLatency(identifier, *now, data, Role::kSpeed, "speed_delay", speed_nuisance, options, floor_s, speed_refitted));
  decide(out[1]);
  std::vector<stats::Segment> speed_aligned;
  std::vector<double> steer_refitted;
  if (out[1].apply) {
    if (speed_refitted.size() == params.size()) now = &speed_refitted;
    speed_aligned = AlignSegments(data, {out[1]});
    data = Pointers(speed_aligned);
    // A speed latency pulls the steering's shift (a 250 ms one by -14 ms): the steering once more,
    // on the speed-aligned data; the two passes add up.
    const RoleLatency again =
        JointLatency(identifier, *now, data, Role::kSteeringWheelAngle, "steer_delay", {}, options, floor_s, steer_refitted);
    if (again.determined) {
      const double before = out[0].apply ? out[0].latency_s : 0.0;
      out[0].latency_s = before + again.latency_s;
      out[0].se_s = again.se_s;
      out[0].method = "RSS profile over shifts, then a joint refit of model and shift (again after the speed's)";
      out[0].note.clear();
      decide(out[0]);
      std::vector<RoleLatency> rest = {out[0]};
      rest[0].latency_s = again.latency_s;
      rest[0].apply = out[0].apply || before != 0.0;
      if (rest[0].apply && again.latency_s != 0.0) {
        steer_aligned = AlignSegments(data, rest);
        data = Pointers(steer_aligned);
        if (steer_refitted.size() == params.size()) now = &steer_refitted;
      }
    }
  }
  RoleLatency yaw;
  yaw.role = Role::kYawRate;
  if (two && yaw1.apply) {
    // The joint refit's shift is the yaw rate's latency relative to a_y whatever the steering's
    // (fitted along): no second pass. (A held profile after it, with the refit's parameters less
    // the nuisance's, read 6 ms less on both hidden-latency runs.)
    yaw = yaw1;
  } else if (two) {
    yaw = YawRateProfile(two_or_one, *now, data, options);
    decide(yaw);
  } else {
    yaw.method = "not estimated";
    yaw.note = "the yaw rate drives only the 1 s bank observer; its kinematic shift (a_y = v (r + beta')) is confounded with the side-slip rate";
  }
  out.push_back(yaw);
  for (const RoleLatency& l : out) {
    spdlog::info("alignment: {} latency {:.1f} ± {:.1f} ms ({}){}", config::RoleKey(l.role), 1e3 * l.latency_s,
                 1e3 * l.se_s, l.method, l.note.empty() ? "" : ": " + l.note);
  }
  return out;
}

}  // namespace ndsid::discover
