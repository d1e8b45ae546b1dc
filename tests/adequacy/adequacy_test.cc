#include "ndsid/adequacy/adequacy.h"

#include <gtest/gtest.h>

#include <cmath>

namespace ndsid::adequacy {
namespace {

stats::Coverage SomeCoverage(int n) {
  stats::Coverage c;
  for (int i = 0; i < n; ++i) {
    gate::GatedSample g;
    g.verdict = gate::Verdict::kAccepted;
    g.sample.speed_mps = 20;
    g.sample.lat_accel_mps2 = std::sin(i * 0.37);
    c.Add(g);
  }
  return c;
}

config::AdequacyConfig Cfg() {
  config::AdequacyConfig c;
  c.tolerance = 0.01;
  c.hold_h = 2.0;
  c.change_window_h = 2.0;
  c.kl_threshold = 0.01;
  return c;
}

// Catches: ADEQUATE claimed before the hold period, or never reached once EG is stable.
TEST(AdequacyTracker, CollectingThenConvergingThenAdequate) {
  Tracker t(Cfg());
  std::vector<State> states;
  for (int k = 1; k <= 40; ++k) {
    const double h = 0.25 * k;
    // EG approaches 0.003 like 1/h; standard error shrinks like 1/sqrt(h).
    const double eg = 0.003 * (1 + 0.05 / h);
    const Report r = t.Update(h, eg, 0.003 * 0.02 / std::sqrt(h), SomeCoverage(static_cast<int>(1000 * h)));
    states.push_back(r.state);
    if (h < 2.0) EXPECT_EQ(r.state, State::kCollecting) << h;
    if (r.state == State::kAdequate) {
      EXPECT_LT(r.rel_change, 0.01);
      EXPECT_LT(r.rel_se, 0.01);
      EXPECT_GE(r.hours_under_tolerance, 2.0);
    }
  }
  EXPECT_EQ(states.back(), State::kAdequate);
  EXPECT_NE(std::find(states.begin(), states.end(), State::kConverging), states.end());
}

// Catches: a drifting EG (e.g. a mass change) reported as adequate.
TEST(AdequacyTracker, DriftingEgNeverAdequate) {
  Tracker t(Cfg());
  for (int k = 1; k <= 60; ++k) {
    const double h = 0.25 * k;
    const Report r = t.Update(h, 0.003 * (1 + 0.01 * h), 1e-6, SomeCoverage(static_cast<int>(1000 * h)));
    EXPECT_NE(r.state, State::kAdequate) << h;
  }
}

// k quarter hours of driving that all cover the same conditions (coverage growth exactly 0).
stats::Coverage SteadyCoverage(int k) {
  const stats::Coverage quarter = SomeCoverage(250);
  stats::Coverage c;
  for (int i = 0; i < k; ++i) c.Merge(quarter);
  return c;
}

// The hours at which a vehicle with a steady EG (the data's `eg`, relative se 0.5 %) first
// reads ADEQUATE, one estimate every quarter hour, with `prior` (none: hours 0).
double FirstAdequateHours(const PriorCredit& prior, double eg, std::vector<Report>* reports = nullptr) {
  Tracker t(Cfg());
  for (int k = 1; k <= 40; ++k) {
    const double h = 0.25 * k;
    const Report r = t.Update(h, eg, 0.005 * eg, SteadyCoverage(k), prior);
    if (reports) reports->push_back(r);
    if (r.state == State::kAdequate) return h;
  }
  return -1;
}

// Catches: a prior not counted as driving (adequacy only after change window + hold of the
// vehicle's own hours), the hold credited to the prior (adequate before hold_h of the vehicle's
// own driving), or more credit than the prior's hours.
TEST(AdequacyTracker, APriorCountsAsItsHoursOfDrivingBeforeTheFirst) {
  const double eg = 0.003;
  const double alone = FirstAdequateHours({}, eg);
  EXPECT_GE(alone, 4.0);  // change window 2 h, then the hold of 2 h
  EXPECT_LE(alone, 4.25);
  std::vector<Report> reports;
  const double with = FirstAdequateHours({3.0, eg * 1.002}, eg, &reports);  // a prior worth more than the window
  EXPECT_GE(with, 2.0);   // the hold is the vehicle's own
  EXPECT_LE(with, 2.5);   // judged from the second estimate on (coverage over the second half)
  EXPECT_TRUE(reports[1].change_from_prior);
  EXPECT_NEAR(reports[1].rel_change, 0.002 / 1.0, 1e-6);
  EXPECT_NE(reports[1].explanation.find("from its priors' EG (the priors counted as 3.00 h"), std::string::npos)
      << reports[1].explanation;
  EXPECT_FALSE(reports.back().change_from_prior);  // past the window, against its own history
  const double short_prior = FirstAdequateHours({1.0, eg}, eg);  // reaches the window's start at 1 h
  EXPECT_GE(short_prior, 3.0);
  EXPECT_LE(short_prior, 3.25);
}

// Catches: a prior that disagrees with the vehicle's data hiding that (adequate early).
TEST(AdequacyTracker, APriorTheDataContradictGivesNoHead) {
  std::vector<Report> reports;
  const double with = FirstAdequateHours({3.0, 0.003 * 1.03}, 0.003, &reports);
  EXPECT_GE(with, 4.0);
  EXPECT_EQ(reports[1].state, State::kConverging);
  EXPECT_NEAR(reports[1].rel_change, 0.03, 1e-9);
}

// Catches: the credit's hours not data_hours * share / (1 - share), or a credit without a prior EG.
TEST(AdequacyTracker, CreditOfAPriorsInformationShare) {
  EXPECT_DOUBLE_EQ(CreditOf(0.75, 2.0, 0.003).hours, 6.0);
  EXPECT_DOUBLE_EQ(CreditOf(0.75, 2.0, 0.003).eg, 0.003);
  EXPECT_DOUBLE_EQ(CreditOf(0.0, 2.0, 0.003).hours, 0.0);
  EXPECT_DOUBLE_EQ(CreditOf(0.5, 2.0, 0.0).hours, 0.0);
  EXPECT_DOUBLE_EQ(CreditOf(1.0, 2.0, 0.003).hours, kMaxPriorHours);
}

TEST(AdequacyTracker, RoundTripKeepsHistory) {
  Tracker t(Cfg());
  for (int k = 1; k <= 12; ++k) t.Update(0.5 * k, 0.003, 1e-6, SomeCoverage(500 * k));
  Tracker u(Cfg());
  u.FromJson(JsonIn(ParseCbor(ToCbor(t.ToJson()), "t"), "adequacy"));
  ASSERT_EQ(u.history().size(), t.history().size());
  EXPECT_DOUBLE_EQ(u.history().back().eg, 0.003);
  const Report a = t.Update(6.5, 0.003, 1e-6, SomeCoverage(6500));
  const Report b = u.Update(6.5, 0.003, 1e-6, SomeCoverage(6500));
  EXPECT_EQ(a.state, b.state);
  EXPECT_DOUBLE_EQ(a.hours_under_tolerance, b.hours_under_tolerance);
  EXPECT_THROW(u.FromJson(JsonIn(nlohmann::json("garbage"), "adequacy")), CodecError);
}

// Catches: a state file claiming a 10-million-point history making the loader allocate it
// (a CBOR array header claims it in 5 bytes): the claim costs nothing until the points are
// there, a history beyond the limit is refused with the limit named, and a rejected state
// leaves the tracker untouched.
TEST(AdequacyTracker, FromJsonBoundsTheHistory) {
  Tracker t(Cfg());
  const nlohmann::json point = {{"gated_hours", 1.0}, {"eg", 0.003}, {"eg_se", 1e-6}, {"kl", -1.0}};
  // {"history": [10 000 000 points claimed, 1 there] ...}: the CBOR ends early.
  std::string claim = ToCbor(nlohmann::json{{"history", nlohmann::json::array({point})}});
  const std::string one_point_array = "\x81";
  const size_t at = claim.find(one_point_array);
  ASSERT_NE(at, std::string::npos);
  claim.replace(at, 1, std::string("\x9a\x00\x98\x96\x80", 5));  // array(10 000 000)
  try {
    ParseCbor(claim, "adequacy state");
    FAIL() << "accepted";
  } catch (const CodecError& e) {
    EXPECT_NE(std::string(e.what()).find("adequacy state"), std::string::npos) << e.what();
  }
  nlohmann::json many = Tracker(Cfg()).ToJson();
  many["history"] = nlohmann::json::array();
  for (size_t i = 0; i <= Tracker::kMaxHistoryPoints; ++i) many["history"].push_back(point);
  try {
    t.FromJson(JsonIn(many, "state.adequacy"));
    FAIL() << "accepted";
  } catch (const CodecError& e) {
    EXPECT_NE(std::string(e.what()).find("state.adequacy.history: 100001 entries, at most 100000"), std::string::npos)
        << e.what();
  }
  EXPECT_TRUE(t.history().empty()) << "a rejected state leaves the tracker untouched";
}

}  // namespace
}  // namespace ndsid::adequacy
