// Every number of the vehicle YAML is range-checked with a located error
// (docs/reliability.md): `lcm.status_rate_hz: 1e-300` and `sync.latency_s: 1e15` overflowed a
// conversion to a period later; a YAML complex key escaped as a yaml-cpp exception (exit 1
// instead of 78).
#include <gtest/gtest.h>

#include <string>
#include <utility>

#include "minimal_config.h"
#include "ndsid/config/config.h"

namespace ndsid::config {
namespace {

using testing::ErrorOf;
using testing::kMinimal;

// Catches: a positive-but-absurd number passing a "> 0" check and overflowing downstream.
TEST(ConfigLimits, AbsurdNumbersAreLocatedErrors) {
  const std::pair<const char*, const char*> cases[] = {
      {"lcm:\n  status_rate_hz: 1e-300\n", "car.yaml:9: lcm.status_rate_hz: value 1e-300 out of range [0.01, 1000]"},
      {"lcm:\n  monitor_rate_hz: 1e300\n", "car.yaml:9: lcm.monitor_rate_hz: value 1e+300 out of range"},
      {"sync:\n  latency_s: 1e15\n", "car.yaml:9: sync.latency_s: value 1e+15 out of range [0.001, 10]"},
      {"gate:\n  drive_gap_s: 1e300\n", "car.yaml:9: gate.drive_gap_s: value 1e+300 out of range"},
      {"identification:\n  period_s: 1e-9\n", "car.yaml:9: identification.period_s: value 1e-09 out of range"},
      {"identification:\n  max_iterations: -5\n", "car.yaml:9: identification.max_iterations: value -5 out of range"},
      {"adequacy:\n  hold_h: 1e30\n", "car.yaml:9: adequacy.hold_h: value 1e+30 out of range"},
      {"identification:\n  relinearize_sigma: 0\n", "car.yaml:9: identification.relinearize_sigma: value 0 out of range [0.01, 100]"},
      {"identification:\n  full_refit_every: -1\n", "car.yaml:9: identification.full_refit_every: value -1 out of range"},
  };
  for (const auto& [yaml, want] : cases) {
    const std::string e = ErrorOf(std::string(kMinimal) + yaml);
    EXPECT_EQ(e.rfind(want, 0), 0u) << "got: " << e << "\nwant: " << want;
  }
  // The documented defaults and the bundled configs' values stay inside.
  EXPECT_EQ(ErrorOf(std::string(kMinimal) + "lcm:\n  status_rate_hz: 1\n  monitor_rate_hz: 10\nsync:\n  latency_s: 0.05\n"), "");
  EXPECT_EQ(ErrorOf(std::string(kMinimal) + "identification:\n  incremental: false\n  relinearize_sigma: 2\n  full_refit_every: 0\n"), "");
  EXPECT_NE(ErrorOf(std::string(kMinimal) + "identification:\n  incremental: maybe\n").find("car.yaml:9: identification.incremental"),
            std::string::npos);
}

// Catches: a non-finite number in a list (valid_values: [.nan]) accepted.
TEST(ConfigLimits, NonFiniteListEntryIsALocatedError) {
  std::string y = kMinimal;
  y.replace(y.find("  steering"), 0, "  reverse_gear: {message: M, signal: R, active_values: [1, .nan]}\n");
  EXPECT_NE(ErrorOf(y).find("car.yaml:5: signals.reverse_gear.active_values: must be finite"), std::string::npos)
      << ErrorOf(y);
}

// Catches: a complex key (a YAML sequence or mapping used as a key) escaping as YAML::Exception,
// which the binaries turn into exit 1 instead of the configuration error 78.
TEST(ConfigLimits, ComplexKeyIsAConfigError) {
  EXPECT_NE(ErrorOf(std::string(kMinimal) + "? [a, b]\n: 1\n").find("car.yaml:8:"), std::string::npos);
  EXPECT_NE(ErrorOf(std::string(kMinimal) + "model:\n  formulas:\n    ? {x: 1}\n    : {a_y_meas: a_y}\n").find("car.yaml:"),
            std::string::npos);
  EXPECT_NE(ErrorOf(std::string(kMinimal) + "gate: {[1]: 2}\n").find("car.yaml:8:"), std::string::npos);
}

}  // namespace
}  // namespace ndsid::config
