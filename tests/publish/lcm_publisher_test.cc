// LcmPublisher: our messages on the configured channels, decodable with the generated types,
// every field carried; bad URLs are configuration errors.
#include "ndsid/publish/lcm_publisher.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <lcm/lcm-cpp.hpp>
#include <map>

#include "ndsid/common/error.h"
#include "ndsid/estimate_t.hpp"
#include "ndsid/monitor_t.hpp"
#include "ndsid/status_t.hpp"

namespace ndsid::publish {
namespace {

EstimateMessage SampleEstimate() {
  EstimateMessage m;
  m.utime = 1'700'000'123'456'789;
  m.publish_utime = 42;
  m.vehicle = "example-cmax";
  m.identifications = 7;
  m.valid = true;
  m.eg_rad_per_mps2 = 2.25e-3;
  m.eg_sigma_rad_per_mps2 = 1.5e-5;
  m.eg_deg_per_g = 1.2646;
  m.eg_sigma_deg_per_g = 0.0084;
  const char* names[] = {"m", "Jz", "cv", "ch", "lv", "is"};
  for (int i = 0; i < 6; ++i) m.params.push_back({names[i], "u", 10.0 * i + 1, 0.5 * i, i == 0, i == 4});
  m.rmse_train_mps2 = 0.11;
  m.rmse_validation_mps2 = 0.13;
  m.se_method = "cluster-robust (12 chunks)";
  m.gated_hours = 3.5;
  m.window_hours = 3.25;
  m.training_segments = 40;
  m.validation_segments = 9;
  m.steady_state_valid = true;
  m.steady_state_eg_rad_per_mps2 = 2.3e-3;
  m.steady_state_eg_sigma_rad_per_mps2 = 4e-5;
  m.steady_state_steer_ratio = 14.9;
  m.adequacy_state = "CONVERGING";
  m.adequacy_rel_change = 0.02;
  m.adequacy_rel_sigma = 0.007;
  m.adequacy_kl_growth = 0.03;
  m.adequacy_hours_under_tolerance = 0.5;
  m.adequacy_explanation = "EG moved 2.00 %";
  m.effects = {"steer_offset", "tyre_relaxation"};
  m.checks = {{"converged", "passed", 12, "solver ended CONVERGENCE after 12 iterations"},
              {"halves", "failed", -3.4, "EG of two halves ... -3.40 combined sigma"}};
  return m;
}

TEST(LcmPublisher, EstimateEncodingCarriesEveryField) {
  const EstimateMessage m = SampleEstimate();
  const EstimateMessage d = DecodeEstimate(EncodeEstimate(m));
  EXPECT_EQ(d.utime, m.utime);
  EXPECT_EQ(d.vehicle, m.vehicle);
  EXPECT_EQ(d.identifications, 7);
  EXPECT_TRUE(d.valid);
  EXPECT_EQ(d.eg_rad_per_mps2, m.eg_rad_per_mps2);
  EXPECT_EQ(d.eg_sigma_deg_per_g, m.eg_sigma_deg_per_g);
  ASSERT_EQ(d.params.size(), 6u);
  for (size_t i = 0; i < 6; ++i) {
    EXPECT_EQ(d.params[i].name, m.params[i].name);
    EXPECT_EQ(d.params[i].value, m.params[i].value);
    EXPECT_EQ(d.params[i].sigma, m.params[i].sigma);
    EXPECT_EQ(d.params[i].fixed, m.params[i].fixed);
    EXPECT_EQ(d.params[i].at_bound, m.params[i].at_bound);
  }
  EXPECT_EQ(d.rmse_validation_mps2, 0.13);
  EXPECT_EQ(d.se_method, m.se_method);
  EXPECT_EQ(d.training_segments, 40);
  EXPECT_EQ(d.steady_state_steer_ratio, 14.9);
  EXPECT_EQ(d.adequacy_state, "CONVERGING");
  EXPECT_EQ(d.adequacy_kl_growth, 0.03);
  EXPECT_EQ(d.adequacy_explanation, m.adequacy_explanation);
  EXPECT_EQ(d.effects, m.effects);
  ASSERT_EQ(d.checks.size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(d.checks[i].name, m.checks[i].name);
    EXPECT_EQ(d.checks[i].verdict, m.checks[i].verdict);
    EXPECT_EQ(d.checks[i].value, m.checks[i].value);
    EXPECT_EQ(d.checks[i].message, m.checks[i].message);
  }
}

TEST(LcmPublisher, WritesDecodableMessagesOnConfiguredChannels) {
  const std::string log =
      (std::filesystem::temp_directory_path() / ("ndsid_publish_" + std::to_string(::getpid()) + ".lcmlog")).string();
  {
    // LCM's file provider writes what is published into an LCM log: no network needed.
    LcmPublisher pub("file://" + log + "?mode=w", {"E_CHAN", "S_CHAN", "M_CHAN"});
    pub.PublishEstimate(SampleEstimate());
    StatusMessage s;
    s.source = "socketcan can0";
    s.source_state = "DISCONNECTED";
    s.frames_read = 123;
    s.gate_reason = {"accepted", "below_min_speed", "extra-without-count"};
    s.gate_count = {100, 23};
    s.standstill_lat_accel_mps2 = 0.12;
    pub.PublishStatus(s);
    MonitorMessage mo;
    mo.utime = 5;
    mo.lat_accel_mps2 = 1.5;
    mo.lat_accel_model_mps2 = 1.4;
    mo.model_valid = true;
    mo.verdict = "accepted";
    pub.PublishMonitor(mo);
    EXPECT_EQ(pub.counters().estimates, 1u);
    EXPECT_EQ(pub.counters().statuses, 1u);
    EXPECT_EQ(pub.counters().monitors, 1u);
    EXPECT_EQ(pub.counters().failures, 0u);
  }
  lcm::LogFile file(log, "r");
  ASSERT_TRUE(file.good());
  std::map<std::string, std::string> by_channel;
  while (const lcm::LogEvent* ev = file.readNextEvent()) {
    by_channel[ev->channel] = std::string(static_cast<const char*>(ev->data), ev->datalen);
  }
  std::filesystem::remove(log);
  ASSERT_EQ(by_channel.size(), 3u);
  ndsid::estimate_t e;
  ASSERT_GE(e.decode(by_channel["E_CHAN"].data(), 0, static_cast<int>(by_channel["E_CHAN"].size())), 0);
  EXPECT_EQ(e.eg_rad_per_mps2, 2.25e-3);
  EXPECT_EQ(e.num_params, 6);
  ndsid::status_t st;
  ASSERT_GE(st.decode(by_channel["S_CHAN"].data(), 0, static_cast<int>(by_channel["S_CHAN"].size())), 0);
  EXPECT_EQ(st.num_gate_reasons, 2);  // parallel arrays cut to the shorter one
  EXPECT_EQ(st.gate_reason[1], "below_min_speed");
  EXPECT_EQ(st.gate_count[1], 23);
  EXPECT_EQ(st.source_state, "DISCONNECTED");
  ndsid::monitor_t mo;
  ASSERT_GE(mo.decode(by_channel["M_CHAN"].data(), 0, static_cast<int>(by_channel["M_CHAN"].size())), 0);
  EXPECT_EQ(mo.lat_accel_model_mps2, 1.4);
  EXPECT_TRUE(mo.model_valid);
}

TEST(LcmPublisher, UnusableUrlIsAConfigurationError) {
  EXPECT_THROW(LcmPublisher("nosuchprovider://x", {}), ConfigError);
}

void PutInt32(std::string& b, size_t at, int32_t v) {
  const auto u = static_cast<uint32_t>(v);
  for (int i = 0; i < 4; ++i) b[at + i] = static_cast<char>(u >> (24 - 8 * i));
}

// Catches: lcm-gen's decode trusting the counts and lengths in the buffer: num_params = -1 or
// 10^9 made it allocate without limit, a string length of 0 made it copy SIZE_MAX bytes.
// DecodeEstimate must refuse such buffers with an Error, and every truncation of a good one.
TEST(LcmPublisher, DecodeEstimateRefusesImplausibleCountsAndLengths) {
  const std::string good = EncodeEstimate(SampleEstimate());
  // fingerprint, utime, publish_utime, vehicle (4 + 13), identifications, valid, reason (4 + 1), 4 doubles
  const size_t vehicle_at = 24, num_params_at = 24 + 17 + 4 + 1 + 5 + 32;
  ASSERT_EQ(good.substr(num_params_at, 4), std::string("\0\0\0\6", 4)) << "layout of estimate_t changed";
  for (int32_t n : {-1, 1'000'000'000, 5000}) {
    std::string b = good;
    PutInt32(b, num_params_at, n);
    EXPECT_THROW(DecodeEstimate(b), Error) << n;
  }
  const size_t last_effect_at = good.find("tyre_relaxation") - 4;
  ASSERT_EQ(good.substr(last_effect_at, 4), std::string("\0\0\0\x10", 4));
  const size_t last_message_at = good.size() - 4 - sizeof("EG of two halves ... -3.40 combined sigma");  // the last string
  ASSERT_EQ(good.substr(last_message_at, 4), std::string("\0\0\0\x2a", 4));
  for (int32_t len : {0, -7}) {
    for (size_t at : {vehicle_at, last_effect_at, last_message_at}) {  // found by the fuzzer: the effects' strings
      std::string b = good;
      PutInt32(b, at, len);
      EXPECT_THROW(DecodeEstimate(b), Error) << len << " at " << at;
    }
  }
  for (size_t cut = 0; cut < good.size(); ++cut) EXPECT_THROW(DecodeEstimate(good.substr(0, cut)), Error) << cut;
  EXPECT_EQ(DecodeEstimate(good).params.size(), 6u);
}

}  // namespace
}  // namespace ndsid::publish
