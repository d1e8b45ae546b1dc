// The truth file (YAML, written as text) and the optional 100 Hz signals CSV of a simulation.
#pragma once

#include <array>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "ndsid/config/simulation_config.h"
#include "ndsid/sim/simulator.h"

namespace ndsid::sim {

// Collects what the truth file says about the drives, drive by drive (no series kept).
class TruthSummary {
 public:
  struct Drive {
    int index;
    int64_t start_epoch_ns;
    int driver;
    model::Params<double> params;
    double self_steer_gradient;
    DriveStats stats;
    double gyro_offset_degps = 0;
  };
  void Add(const DriveResult& drive);
  const std::vector<Drive>& drives() const { return drives_; }
  double hours() const;
  double km() const;
  // |a_y,meas| of moving samples (|v| > 1 m/s) over all drives: quantile p, fraction below x.
  double AbsLatAccelQuantile(double p) const;
  double FractionBelow(double abs_ay_mps2) const;
  double GatedFraction() const;

 private:
  static constexpr double kBin_mps2 = 0.01;
  std::vector<Drive> drives_;
  std::array<uint64_t, 3000> histogram_{};  // 0..30 m/s^2 in 0.01 bins (last bin: above)
  uint64_t moving_ = 0, samples_ = 0, gated_ = 0;
};

// Text of the truth YAML. `files` lists what was written (name: path).
std::string TruthYaml(const config::SimulationConfig& config, const std::vector<DriverProfile>& drivers,
                      const TruthSummary& summary, const std::vector<std::pair<std::string, std::string>>& files);

// 100 Hz CSV of the true and measured signals (degrees and km/h, as an engineer plots them).
class SignalsCsvWriter {
 public:
  explicit SignalsCsvWriter(const std::string& path);  // throws ndsid::Error
  ~SignalsCsvWriter();
  void WriteDrive(const DriveResult& drive);
  void Close();

 private:
  std::string path_;
  FILE* file_ = nullptr;
};

}  // namespace ndsid::sim
