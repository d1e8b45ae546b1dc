#include "ndsid/publish/lcm_publisher.h"

#include <spdlog/spdlog.h>

#include <chrono>
#include <lcm/lcm-cpp.hpp>
#include <lcm/lcm.h>

#include "ndsid/common/error.h"
#include "ndsid/estimate_t.hpp"
#include "ndsid/monitor_t.hpp"
#include "ndsid/status_t.hpp"

namespace ndsid::publish {

namespace {

constexpr int64_t kFailureLogInterval_ns = 10'000'000'000;  // at most one send-failure line per 10 s

ndsid::estimate_t ToLcm(const EstimateMessage& m) {
  ndsid::estimate_t o{};  // value-initialised: LCM types have no constructor
  o.utime = m.utime;
  o.publish_utime = m.publish_utime;
  o.vehicle = m.vehicle;
  o.identifications = m.identifications;
  o.valid = m.valid;
  o.reason = m.reason;
  o.eg_rad_per_mps2 = m.eg_rad_per_mps2;
  o.eg_sigma_rad_per_mps2 = m.eg_sigma_rad_per_mps2;
  o.eg_deg_per_g = m.eg_deg_per_g;
  o.eg_sigma_deg_per_g = m.eg_sigma_deg_per_g;
  o.num_params = static_cast<int32_t>(m.params.size());
  for (const ParameterValue& p : m.params) {
    o.param_name.push_back(p.name);
    o.param_unit.push_back(p.unit);
    o.param_value.push_back(p.value);
    o.param_sigma.push_back(p.sigma);
    o.param_fixed.push_back(p.fixed);
    o.param_at_bound.push_back(p.at_bound);
  }
  o.rmse_train_mps2 = m.rmse_train_mps2;
  o.rmse_validation_mps2 = m.rmse_validation_mps2;
  o.se_method = m.se_method;
  o.gated_hours = m.gated_hours;
  o.window_hours = m.window_hours;
  o.training_segments = m.training_segments;
  o.validation_segments = m.validation_segments;
  o.steady_state_valid = m.steady_state_valid;
  o.steady_state_eg_rad_per_mps2 = m.steady_state_eg_rad_per_mps2;
  o.steady_state_eg_sigma_rad_per_mps2 = m.steady_state_eg_sigma_rad_per_mps2;
  o.steady_state_steer_ratio = m.steady_state_steer_ratio;
  o.adequacy_state = m.adequacy_state;
  o.adequacy_rel_change = m.adequacy_rel_change;
  o.adequacy_rel_sigma = m.adequacy_rel_sigma;
  o.adequacy_kl_growth = m.adequacy_kl_growth;
  o.adequacy_hours_under_tolerance = m.adequacy_hours_under_tolerance;
  o.adequacy_explanation = m.adequacy_explanation;
  o.num_effects = static_cast<int32_t>(m.effects.size());
  o.effects = m.effects;
  o.num_checks = static_cast<int32_t>(m.checks.size());
  for (const EstimateMessage::CheckValue& c : m.checks) {
    o.check_name.push_back(c.name);
    o.check_verdict.push_back(c.verdict);
    o.check_value.push_back(c.value);
    o.check_message.push_back(c.message);
  }
  return o;
}

ndsid::status_t ToLcm(const StatusMessage& m) {
  ndsid::status_t o{};
  o.utime = m.utime;
  o.publish_utime = m.publish_utime;
  o.vehicle = m.vehicle;
  o.source = m.source;
  o.source_state = m.source_state;
  o.frames_read = m.frames_read;
  o.frames_decoded = m.frames_decoded;
  o.frames_unknown = m.frames_unknown;
  o.frames_too_short = m.frames_too_short;
  o.malformed = m.malformed;
  o.bus_errors = m.bus_errors;
  o.dropped = m.dropped;
  o.reconnects = m.reconnects;
  o.time_backwards = m.time_backwards;
  o.frames_skipped_resume = m.frames_skipped_resume;
  const size_t n = std::min(m.gate_reason.size(), m.gate_count.size());
  o.num_gate_reasons = static_cast<int32_t>(n);
  o.gate_reason.assign(m.gate_reason.begin(), m.gate_reason.begin() + static_cast<std::ptrdiff_t>(n));
  o.gate_count.assign(m.gate_count.begin(), m.gate_count.begin() + static_cast<std::ptrdiff_t>(n));
  o.drives = m.drives;
  o.gated_hours = m.gated_hours;
  o.standstill_samples = m.standstill_samples;
  o.standstill_lat_accel_mps2 = m.standstill_lat_accel_mps2;
  o.identification_running = m.identification_running;
  o.last_persist_age_s = m.last_persist_age_s;
  return o;
}

ndsid::monitor_t ToLcm(const MonitorMessage& m) {
  ndsid::monitor_t o{};
  o.utime = m.utime;
  o.lat_accel_mps2 = m.lat_accel_mps2;
  o.lat_accel_model_mps2 = m.lat_accel_model_mps2;
  o.yaw_rate_radps = m.yaw_rate_radps;
  o.yaw_rate_model_radps = m.yaw_rate_model_radps;
  o.speed_mps = m.speed_mps;
  o.steer_rad = m.steer_rad;
  o.model_valid = m.model_valid;
  o.verdict = m.verdict;
  return o;
}

template <typename T>
std::string Encode(const T& msg) {
  std::string buf(static_cast<size_t>(msg.getEncodedSize()), '\0');
  msg.encode(buf.data(), 0, static_cast<int>(buf.size()));
  return buf;
}

int64_t MonotonicNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

}  // namespace

struct LcmPublisher::Impl {
  explicit Impl(const std::string& url) : lcm(url) {}
  lcm::LCM lcm;
  int64_t last_failure_log_ns = 0;
};

LcmPublisher::LcmPublisher(const std::string& url, LcmChannels channels)
    : impl_(std::make_unique<Impl>(url)), url_(url), channels_(std::move(channels)) {
  if (!impl_->lcm.good()) {
    throw ConfigError("lcm.url: cannot create LCM from '" + url +
                      "' (a udpm:// URL needs a multicast route; see docs/monitoring.md)");
  }
}

LcmPublisher::~LcmPublisher() = default;

namespace {
// Converts and sends; false when the transport refused it (or the encode buffer could not be had).
template <typename M>
bool Send(lcm::LCM& lcm, const std::string& channel, const M& m) noexcept {
  try {
    const auto msg = ToLcm(m);
    return lcm.publish(channel, &msg) == 0;
  } catch (...) {
    return false;
  }
}
}  // namespace

void LcmPublisher::Count(bool ok, uint64_t& sent, const std::string& channel) noexcept {
  if (ok) {
    ++sent;
    return;
  }
  ++counters_.failures;
  const int64_t now = MonotonicNs();
  if (now - impl_->last_failure_log_ns > kFailureLogInterval_ns) {
    impl_->last_failure_log_ns = now;
    spdlog::warn("lcm: publish on {} via {} failed ({} failures so far)", channel, url_, counters_.failures);
  }
}

void LcmPublisher::PublishEstimate(const EstimateMessage& m) noexcept {
  Count(Send(impl_->lcm, channels_.estimate, m), counters_.estimates, channels_.estimate);
}
void LcmPublisher::PublishStatus(const StatusMessage& m) noexcept {
  Count(Send(impl_->lcm, channels_.status, m), counters_.statuses, channels_.status);
}
void LcmPublisher::PublishMonitor(const MonitorMessage& m) noexcept {
  Count(Send(impl_->lcm, channels_.monitor, m), counters_.monitors, channels_.monitor);
}

std::string EncodeEstimate(const EstimateMessage& m) { return Encode(ToLcm(m)); }
std::string EncodeStatus(const StatusMessage& m) { return Encode(ToLcm(m)); }
std::string EncodeMonitor(const MonitorMessage& m) { return Encode(ToLcm(m)); }

namespace {

// lcm-gen's decode sizes its arrays from the counts in the buffer before reading them, so a
// crafted count (negative, or 10^9) would make it allocate without limit. This walks the
// encoded estimate_t (big-endian, strings as int32 length incl. NUL + bytes) up to each count and
// checks it (and every string length >= 1) against kMaxDecodedElements and against the bytes left (every element takes >= 1).
class EstimateLayoutCheck {
 public:
  explicit EstimateLayoutCheck(const std::string& b) : b_(b) {}
  bool Ok() {
    Skip(8 + 8 + 8);  // fingerprint, utime, publish_utime
    String();         // vehicle
    Skip(4 + 1);      // identifications, valid
    String();         // reason
    Skip(4 * 8);      // eg, sigma (two units)
    const int64_t n = Count();
    for (int64_t i = 0; ok_ && i < n; ++i) String();  // param_name
    for (int64_t i = 0; ok_ && i < n; ++i) String();  // param_unit
    Skip(n * (8 + 8 + 1 + 1));                        // value, sigma, fixed, at_bound
    Skip(2 * 8);                                      // rmse train / validation
    String();                                         // se_method
    Skip(2 * 8 + 2 * 4 + 1 + 3 * 8);                  // hours, segments, steady state
    String();                                         // adequacy_state
    Skip(4 * 8);
    String();  // adequacy_explanation
    const int64_t effects = Count();
    for (int64_t i = 0; ok_ && i < effects; ++i) String();  // effects
    const int64_t checks = Count();
    for (int64_t i = 0; ok_ && i < checks; ++i) String();  // check_name
    for (int64_t i = 0; ok_ && i < checks; ++i) String();  // check_verdict
    Skip(checks * 8);                                      // check_value
    for (int64_t i = 0; ok_ && i < checks; ++i) String();  // check_message
    return ok_;
  }

 private:
  static constexpr int64_t kMaxDecodedElements = 4096;
  int64_t Int32() {
    if (!ok_ || b_.size() - pos_ < 4) return ok_ = false, 0;
    const auto* p = reinterpret_cast<const unsigned char*>(b_.data() + pos_);
    pos_ += 4;
    return static_cast<int32_t>((uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | p[3]);
  }
  void Skip(int64_t n) {
    if (!ok_ || n < 0 || static_cast<uint64_t>(n) > b_.size() - pos_) ok_ = false;
    else pos_ += static_cast<size_t>(n);
  }
  void String() {  // lcm-gen assigns length - 1 bytes: a length below 1 must not reach it
    const int64_t n = Int32();
    if (n < 1) ok_ = false;
    Skip(n);
  }
  int64_t Count() {
    const int64_t n = Int32();
    if (n < 0 || n > kMaxDecodedElements || static_cast<uint64_t>(n) > b_.size() - pos_) ok_ = false;
    return ok_ ? n : 0;
  }
  const std::string& b_;
  size_t pos_ = 0;
  bool ok_ = true;
};

}  // namespace

EstimateMessage DecodeEstimate(const std::string& bytes) {
  ndsid::estimate_t o{};  // value-initialised: LCM types have no constructor
  if (!EstimateLayoutCheck(bytes).Ok()) throw Error("estimate_t: cannot decode (truncated or implausible counts)");
  if (o.decode(bytes.data(), 0, static_cast<int>(bytes.size())) < 0) throw Error("estimate_t: cannot decode");
  EstimateMessage m;
  m.utime = o.utime;
  m.publish_utime = o.publish_utime;
  m.vehicle = o.vehicle;
  m.identifications = o.identifications;
  m.valid = o.valid;
  m.reason = o.reason;
  m.eg_rad_per_mps2 = o.eg_rad_per_mps2;
  m.eg_sigma_rad_per_mps2 = o.eg_sigma_rad_per_mps2;
  m.eg_deg_per_g = o.eg_deg_per_g;
  m.eg_sigma_deg_per_g = o.eg_sigma_deg_per_g;
  for (int i = 0; i < o.num_params; ++i) {
    m.params.push_back({o.param_name[i], o.param_unit[i], o.param_value[i], o.param_sigma[i],
                        static_cast<bool>(o.param_fixed[i]), static_cast<bool>(o.param_at_bound[i])});
  }
  m.rmse_train_mps2 = o.rmse_train_mps2;
  m.rmse_validation_mps2 = o.rmse_validation_mps2;
  m.se_method = o.se_method;
  m.gated_hours = o.gated_hours;
  m.window_hours = o.window_hours;
  m.training_segments = o.training_segments;
  m.validation_segments = o.validation_segments;
  m.steady_state_valid = o.steady_state_valid;
  m.steady_state_eg_rad_per_mps2 = o.steady_state_eg_rad_per_mps2;
  m.steady_state_eg_sigma_rad_per_mps2 = o.steady_state_eg_sigma_rad_per_mps2;
  m.steady_state_steer_ratio = o.steady_state_steer_ratio;
  m.adequacy_state = o.adequacy_state;
  m.adequacy_rel_change = o.adequacy_rel_change;
  m.adequacy_rel_sigma = o.adequacy_rel_sigma;
  m.adequacy_kl_growth = o.adequacy_kl_growth;
  m.adequacy_hours_under_tolerance = o.adequacy_hours_under_tolerance;
  m.adequacy_explanation = o.adequacy_explanation;
  m.effects = o.effects;
  for (int i = 0; i < o.num_checks; ++i)
    m.checks.push_back({o.check_name[i], o.check_verdict[i], o.check_value[i], o.check_message[i]});
  return m;
}

std::string LcmVersion() {
  return std::to_string(LCM_MAJOR_VERSION) + "." + std::to_string(LCM_MINOR_VERSION) + "." + std::to_string(LCM_MICRO_VERSION);
}

}  // namespace ndsid::publish
