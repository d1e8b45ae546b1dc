// EstimateSink over LCM (the only stage that links LCM): estimate_t, status_t and monitor_t of
// lcmtypes/ on the channels of config.lcm. Publishing is a non-blocking UDP multicast send for
// udpm:// URLs, so it may run on the reading thread.
#pragma once

#include <memory>
#include <string>

#include "ndsid/publish/estimate_sink.h"

namespace ndsid::publish {

struct LcmChannels {
  std::string estimate = "NDSID_ESTIMATE";
  std::string status = "NDSID_STATUS";
  std::string monitor = "NDSID_MONITOR";
};

class LcmPublisher final : public EstimateSink {
 public:
  // Throws ndsid::ConfigError naming the URL when LCM cannot be created from it (bad URL, no
  // multicast route: see docs/monitoring.md).
  LcmPublisher(const std::string& url, LcmChannels channels);
  ~LcmPublisher() override;
  LcmPublisher(const LcmPublisher&) = delete;
  LcmPublisher& operator=(const LcmPublisher&) = delete;

  void PublishEstimate(const EstimateMessage& m) noexcept override;
  void PublishStatus(const StatusMessage& m) noexcept override;
  void PublishMonitor(const MonitorMessage& m) noexcept override;
  const SinkCounters& counters() const noexcept override { return counters_; }
  const std::string& url() const { return url_; }

 private:
  void Count(bool ok, uint64_t& sent, const std::string& channel) noexcept;
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::string url_;
  LcmChannels channels_;
  SinkCounters counters_;
};

// Conversions to the generated LCM types, encoded (exposed for the round-trip tests).
std::string EncodeEstimate(const EstimateMessage& m);
std::string EncodeStatus(const StatusMessage& m);
std::string EncodeMonitor(const MonitorMessage& m);
EstimateMessage DecodeEstimate(const std::string& bytes);  // throws ndsid::Error on a bad buffer
std::string LcmVersion();  // "1.3.1": the LCM library this was built against (`ndsid version`)

}  // namespace ndsid::publish
