#include "ndsid/stats/accumulator.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "ndsid/common/error.h"

namespace ndsid::stats {

Accumulator::Accumulator(const config::Config& config, double sync_rate_hz)
    : config_(config),
      decimation_(std::max(1, static_cast<int>(std::lround(sync_rate_hz / config.identification.rate_hz)))),
      segment_dt_s_(decimation_ / sync_rate_hz),
      min_segment_samples_(static_cast<size_t>(std::ceil(config.gate.min_segment_s / (decimation_ / sync_rate_hz)))),
      window_s_(config.identification.window_h * 3600.0) {}

void Accumulator::Add(const gate::GatedSample& g) {
  if (g.sample.t_ns <= skip_through_ns_) return;  // re-read after a restart: learned already
  if (g.new_drive || resume_open_) {
    // The first sample after a restore decides whether the restored open drive goes on.
    const bool resume = resume_open_ && drive_open_ && !drives_.empty() && g.sample.t_ns > drives_.back().end_ns &&
                        static_cast<double>(g.sample.t_ns - drives_.back().end_ns) * 1e-9 <= config_.gate.drive_gap_s;
    resume_open_ = false;
    if (resume) {
      // A restart in the middle of a drive: the drive goes on with its number, its distance so
      // far and its held-back data, and the open segment with it when the gate sees the data
      // as contiguous (the daemon re-reads a few seconds before a log's resume point to warm
      // up the sync stage and the gate).
      drive_id_offset_ = drives_.back().drive_id - g.drive_id;
      distance_base_km_ = drives_.back().distance_km - g.drive_distance_m / 1000.0;
    } else {
      CloseSegment();
      CloseDrive();
      distance_base_km_ = 0;
      drives_.push_back({g.drive_id + drive_id_offset_, g.sample.t_ns, g.sample.t_ns, 0, 0, false});
      drive_open_ = true;
      drive_used_ = false;
    }
  }
  if (!drive_open_) {
    drives_.push_back({g.drive_id + drive_id_offset_, g.sample.t_ns, g.sample.t_ns, 0, 0, false});
    drive_open_ = true;
  }
  DriveSummary& d = drives_.back();
  d.end_ns = g.sample.t_ns;
  d.distance_km = distance_base_km_ + g.drive_distance_m / 1000.0;

  const bool accepted = g.verdict == gate::Verdict::kAccepted;
  if (!accepted || g.segment_start) CloseSegment();
  if (accepted) {
    const double period = segment_dt_s_ / decimation_;
    d.gated_s += period;
    (drive_used_ ? steady_ : pending_steady_).Add(g);
    (drive_used_ ? coverage_ : pending_coverage_).Add(g);
    if (drive_used_) {
      gated_s_ += period;
    } else {
      pending_gated_s_ += period;
      ++pending_samples_;
    }
    // Decimate by averaging `decimation_` consecutive samples (a boxcar anti-alias filter).
    if (!segment_open_) {
      current_ = Segment{};
      current_.drive_id = g.drive_id + drive_id_offset_;
      current_.dt_s = segment_dt_s_;
      current_.has_yaw_rate = g.sample.has_yaw_rate;
      current_.has_long_accel = g.sample.has_long_accel;
      current_.has_rear_wheel_diff = g.sample.has_rear_wheel_diff;
      segment_open_ = true;
      summed_ = 0;
    }
    if (summed_ == 0) {
      sum_ = SegmentSample{};
      sum_t0_ns_ = g.sample.t_ns;
    }
    const auto& s = g.sample;
    sum_.steer_rad += static_cast<float>(s.steer_rad);
    sum_.speed_mps += static_cast<float>(s.speed_mps);
    sum_.lat_accel_mps2 += static_cast<float>(s.lat_accel_mps2);
    sum_.yaw_rate_radps += static_cast<float>(s.yaw_rate_radps);
    sum_.long_accel_mps2 += static_cast<float>(s.long_accel_mps2);
    if (s.has_rear_wheel_diff) sum_.rear_wheel_diff_mps += static_cast<float>(s.rear_wheel_diff_mps);
    current_.has_yaw_rate = current_.has_yaw_rate && s.has_yaw_rate;
    current_.has_long_accel = current_.has_long_accel && s.has_long_accel;
    current_.has_rear_wheel_diff = current_.has_rear_wheel_diff && s.has_rear_wheel_diff;
    if (++summed_ == decimation_) {
      const float k = 1.0f / static_cast<float>(decimation_);
      if (current_.samples.empty()) current_.t0_ns = sum_t0_ns_;
      current_.samples.push_back({sum_.steer_rad * k, sum_.speed_mps * k, sum_.lat_accel_mps2 * k,
                                  sum_.yaw_rate_radps * k, sum_.long_accel_mps2 * k, sum_.rear_wheel_diff_mps * k});
      summed_ = 0;
    }
  }
  if (!drive_used_ && d.distance_km >= config_.gate.min_drive_km) CommitPending();
}

void Accumulator::CommitPending() {
  drive_used_ = true;
  if (!drives_.empty()) drives_.back().used = true;
  steady_.Merge(pending_steady_);
  coverage_.Merge(pending_coverage_);
  pending_steady_ = SteadyStateStats{};
  pending_coverage_ = Coverage{};
  gated_s_ += pending_gated_s_;
  pending_gated_s_ = 0;
  pending_samples_ = 0;
  for (auto& s : pending_segments_) {
    window_.push_back(std::move(s));
    RecordStep('c');
  }
  pending_segments_.clear();
}

void Accumulator::CloseSegment() {
  if (!segment_open_) return;
  segment_open_ = false;
  summed_ = 0;
  if (current_.samples.size() < min_segment_samples_) {
    counters_.short_segment_samples += current_.samples.size() * static_cast<uint64_t>(decimation_);
    return;
  }
  auto seg = std::make_shared<const Segment>(std::move(current_));
  if (drive_used_) {
    window_.push_back(std::move(seg));
  } else {
    pending_segments_.push_back(std::move(seg));
  }
  RecordStep(drive_used_ ? 'a' : 'h');
  EvictBeyondWindow();
}

// Evict the oldest segments beyond the window (by accepted duration).
void Accumulator::EvictBeyondWindow() {
  if (record_steps_) return;  // a merge replays the steps instead (Append)
  double total = window_hours() * 3600.0;
  while (!window_.empty() && total - window_.front()->duration_s() >= window_s_) {
    total -= window_.front()->duration_s();
    window_.pop_front();
    ++counters_.evicted_segments;
  }
}

void Accumulator::CloseDrive() {
  if (!drive_open_) return;
  if (!drive_used_) {
    counters_.short_drive_samples += pending_samples_;
    pending_steady_ = SteadyStateStats{};
    pending_coverage_ = Coverage{};
    pending_segments_.clear();
    pending_gated_s_ = 0;
    pending_samples_ = 0;
  }
  drive_open_ = false;
  drive_used_ = false;
}

void Accumulator::Finish() {
  CloseSegment();
  CloseDrive();
  resume_open_ = false;
}

void Accumulator::Append(const Accumulator& later, const std::string& steps, int64_t drive_offset) {
  if (drive_open_ || later.drive_open_) throw Error("accumulator append: a drive is still open (finish both first)");
  if (!later.record_steps_ || later.counters_.evicted_segments != 0)
    throw Error("accumulator append: the later accumulator did not record its window steps from its start");
  const auto appended = static_cast<size_t>(std::count_if(steps.begin(), steps.end(), [](char c) { return c == 'a' || c == 'c'; }));
  if (appended != later.window_.size() || steps.find_first_not_of("ahc") != std::string::npos)
    throw Error("accumulator append: " + std::to_string(steps.size()) + " window steps do not describe " +
                std::to_string(later.window_.size()) + " segments");
  if (!drives_.empty() && !later.drives_.empty() && later.drives_.front().drive_id + drive_offset <= drives_.back().drive_id)
    throw Error("accumulator append: the later drives are not numbered after this one's");
  for (DriveSummary d : later.drives_) {
    d.drive_id += drive_offset;
    drives_.push_back(d);
  }
  steady_.Merge(later.steady_);
  coverage_.Merge(later.coverage_);
  gated_s_ += later.gated_s_;
  counters_.short_drive_samples += later.counters_.short_drive_samples;
  counters_.short_segment_samples += later.counters_.short_segment_samples;
  size_t next = 0;
  for (const char step : steps) {
    if (step != 'h') {
      auto seg = std::make_shared<Segment>(*later.window_[next++]);
      seg->drive_id += drive_offset;
      window_.push_back(std::move(seg));
    }
    RecordStep(step);
    if (step != 'c') EvictBeyondWindow();
  }
}

double Accumulator::window_hours() const {
  double s = 0;
  for (const auto& seg : window_) s += seg->duration_s();
  return s / 3600.0;
}

// ---- Persistence (the learned-state codec, docs/state-format.md) ---------------------------

namespace {

constexpr size_t kMaxSegmentRows = size_t{1} << 26;  // 2^26 decimated samples: weeks of one stretch
constexpr size_t kMaxListed = size_t{1} << 22;       // drives or segments in one state
constexpr size_t kSampleFloats = 5;                  // steer, speed, a_y, yaw rate, a_x

void ToFloats(const SegmentSample& s, float* out) {
  out[0] = s.steer_rad;
  out[1] = s.speed_mps;
  out[2] = s.lat_accel_mps2;
  out[3] = s.yaw_rate_radps;
  out[4] = s.long_accel_mps2;
}

SegmentSample FromFloats(const float* f) { return SegmentSample{f[0], f[1], f[2], f[3], f[4]}; }

nlohmann::json SegmentJson(const Segment& seg) {
  std::vector<float> rows(seg.samples.size() * kSampleFloats);
  for (size_t i = 0; i < seg.samples.size(); ++i) ToFloats(seg.samples[i], &rows[i * kSampleFloats]);
  nlohmann::json j = {{"t0_ns", seg.t0_ns}, {"drive", seg.drive_id}, {"dt_s", seg.dt_s}, {"has_yaw_rate", seg.has_yaw_rate},
                      {"has_long_accel", seg.has_long_accel}, {"samples", FloatsToBinary(rows.data(), rows.size())}};
  if (seg.has_rear_wheel_diff) {  // an optional column: states without it read as before
    std::vector<float> diff(seg.samples.size());
    for (size_t i = 0; i < seg.samples.size(); ++i) diff[i] = seg.samples[i].rear_wheel_diff_mps;
    j["rear_wheel_diff"] = FloatsToBinary(diff.data(), diff.size());
  }
  return j;
}

Segment SegmentFromJson(const JsonIn& in) {
  Segment seg;
  seg.t0_ns = in.Int64("t0_ns");
  seg.drive_id = in.Int64("drive");
  seg.dt_s = in.Finite("dt_s");
  seg.has_yaw_rate = in.Bool("has_yaw_rate");
  seg.has_long_accel = in.Bool("has_long_accel");
  if (!(seg.dt_s > 0) || seg.drive_id < 0) in.Fail("implausible segment (dt_s <= 0 or negative drive)");
  const JsonIn samples = in.At("samples");
  const std::vector<float> f = samples.Floats(kSampleFloats, kMaxSegmentRows);
  for (float v : f) {
    if (!std::isfinite(v)) samples.Fail("non-finite sample");
  }
  seg.samples.resize(f.size() / kSampleFloats);
  for (size_t i = 0; i < seg.samples.size(); ++i) seg.samples[i] = FromFloats(&f[i * kSampleFloats]);
  if (in.Has("rear_wheel_diff")) {
    const JsonIn diff_in = in.At("rear_wheel_diff");
    const std::vector<float> diff = diff_in.Floats(1, kMaxSegmentRows);
    if (diff.size() != seg.samples.size()) diff_in.Fail("not one value per sample");
    for (size_t i = 0; i < diff.size(); ++i) {
      if (!std::isfinite(diff[i])) diff_in.Fail("non-finite sample");
      seg.samples[i].rear_wheel_diff_mps = diff[i];
    }
    seg.has_rear_wheel_diff = true;
  }
  return seg;
}

nlohmann::json SegmentList(const auto& segments) {
  nlohmann::json a = nlohmann::json::array();
  for (const auto& seg : segments) a.push_back(SegmentJson(*seg));
  return a;
}

}  // namespace

nlohmann::json Accumulator::ToJson() const {
  nlohmann::json j;
  j["gated_s"] = gated_s_;
  j["counters"] = {{"short_drive_samples", counters_.short_drive_samples},
                   {"short_segment_samples", counters_.short_segment_samples},
                   {"evicted_segments", counters_.evicted_segments}};
  j["steady_state"] = steady_.ToJson();
  j["coverage"] = coverage_.ToJson();
  j["drives"] = nlohmann::json::array();
  for (const DriveSummary& d : drives_) {
    j["drives"].push_back({{"drive", d.drive_id}, {"start_ns", d.start_ns}, {"end_ns", d.end_ns},
                           {"distance_km", d.distance_km}, {"gated_s", d.gated_s}, {"used", d.used}});
  }
  j["window"] = SegmentList(window_);
  // The drive in progress: used, and what it holds back while short of min_drive_km; its open
  // segment with the decimation's partial sum, so that a restart can go on with it.
  const bool open = drive_open_ && !drives_.empty();
  if (!open) {
    j["open_drive"] = nullptr;
    return j;
  }
  nlohmann::json o;
  o["used"] = drive_used_;
  o["pending_gated_s"] = pending_gated_s_;
  o["pending_samples"] = pending_samples_;
  o["pending_steady_state"] = pending_steady_.ToJson();
  o["pending_coverage"] = pending_coverage_.ToJson();
  o["pending_segments"] = SegmentList(pending_segments_);
  if (segment_open_) {
    float sum[kSampleFloats];
    ToFloats(sum_, sum);
    o["open_segment"] = {{"segment", SegmentJson(current_)}, {"summed", summed_},
                         {"sum", FloatsToBinary(sum, kSampleFloats)}, {"sum_t0_ns", sum_t0_ns_}};
    if (current_.has_rear_wheel_diff) o["open_segment"]["sum_rear_wheel_diff"] = sum_.rear_wheel_diff_mps;
  } else {
    o["open_segment"] = nullptr;
  }
  j["open_drive"] = std::move(o);
  return j;
}

void Accumulator::FromJson(const JsonIn& in) {
  const double gated_s = in.Finite("gated_s");
  if (gated_s < 0) in.At("gated_s").Fail("negative gated time");
  AccumulatorCounters counters;
  const JsonIn c = in.At("counters");
  counters.short_drive_samples = c.UInt64("short_drive_samples");
  counters.short_segment_samples = c.UInt64("short_segment_samples");
  counters.evicted_segments = c.UInt64("evicted_segments");
  SteadyStateStats steady = SteadyStateStats::FromJson(in.At("steady_state"));
  Coverage coverage = Coverage::FromJson(in.At("coverage"));

  const JsonIn jd = in.At("drives");
  std::vector<DriveSummary> drives(jd.Size(kMaxListed));
  int64_t next_drive_id = 0;
  for (size_t i = 0; i < drives.size(); ++i) {
    const JsonIn e = jd.At(i);
    DriveSummary& d = drives[i];
    d.drive_id = e.Int64("drive");
    d.start_ns = e.Int64("start_ns");
    d.end_ns = e.Int64("end_ns");
    d.distance_km = e.Finite("distance_km");
    d.gated_s = e.Finite("gated_s");
    d.used = e.Bool("used");
    if (d.drive_id < 0 || d.end_ns < d.start_ns || d.distance_km < 0 || d.gated_s < 0) e.Fail("implausible drive summary");
    next_drive_id = std::max(next_drive_id, d.drive_id + 1);
  }
  std::deque<std::shared_ptr<const Segment>> window;
  const JsonIn jw = in.At("window");
  const size_t n_segments = jw.Size(kMaxListed);
  for (size_t i = 0; i < n_segments; ++i) {
    window.push_back(std::make_shared<const Segment>(SegmentFromJson(jw.At(i))));
    next_drive_id = std::max(next_drive_id, window.back()->drive_id + 1);
  }
  bool open = false, used = false;
  double pending_gated_s = 0;
  uint64_t pending_samples = 0;
  SteadyStateStats pending_steady;
  Coverage pending_coverage;
  std::vector<std::shared_ptr<const Segment>> pending_segments;
  bool segment_open = false;
  Segment current;
  int64_t summed = 0;
  SegmentSample sum{};
  int64_t sum_t0_ns = 0;
  const JsonIn o = in.At("open_drive");
  if (!o.raw().is_null()) {
    open = true;
    if (drives.empty()) o.Fail("an open drive without its summary");
    used = o.Bool("used");
    pending_gated_s = o.Finite("pending_gated_s");
    pending_samples = o.UInt64("pending_samples");
    if (pending_gated_s < 0) o.Fail("negative pending_gated_s");
    pending_steady = SteadyStateStats::FromJson(o.At("pending_steady_state"));
    pending_coverage = Coverage::FromJson(o.At("pending_coverage"));
    const JsonIn jp = o.At("pending_segments");
    const size_t n_pending = jp.Size(kMaxListed);
    for (size_t i = 0; i < n_pending; ++i) {
      pending_segments.push_back(std::make_shared<const Segment>(SegmentFromJson(jp.At(i))));
      if (pending_segments.back()->drive_id != drives.back().drive_id) jp.At(i).Fail("held-back segment of another drive");
    }
    if (used && (pending_samples != 0 || !pending_segments.empty())) o.Fail("a used drive with held-back data");
    const JsonIn os = o.At("open_segment");
    if (!os.raw().is_null()) {
      segment_open = true;
      current = SegmentFromJson(os.At("segment"));
      summed = os.Int64("summed");
      const JsonIn js = os.At("sum");
      const std::vector<float> f = js.Floats(kSampleFloats, 1);
      if (f.size() != kSampleFloats) js.Fail("needs one row of 5 floats");
      for (float v : f) {
        if (!std::isfinite(v)) js.Fail("non-finite partial sum");
      }
      sum = FromFloats(f.data());
      if (os.Has("sum_rear_wheel_diff")) sum.rear_wheel_diff_mps = static_cast<float>(os.Finite("sum_rear_wheel_diff"));
      sum_t0_ns = os.Int64("sum_t0_ns");
      if (current.drive_id != drives.back().drive_id || summed < 0 || summed >= decimation_)
        os.Fail("implausible open segment (another drive, or a partial sum outside the decimation)");
    }
  }

  // Everything checked: replace the learned state, forget anything open.
  steady_ = std::move(steady);
  coverage_ = std::move(coverage);
  window_ = std::move(window);
  drives_ = std::move(drives);
  gated_s_ = gated_s;
  counters_ = counters;
  pending_steady_ = std::move(pending_steady);
  pending_coverage_ = std::move(pending_coverage);
  pending_segments_ = std::move(pending_segments);
  pending_gated_s_ = pending_gated_s;
  pending_samples_ = pending_samples;
  drive_open_ = resume_open_ = open;
  drive_used_ = open && used;
  segment_open_ = segment_open;
  current_ = std::move(current);
  summed_ = segment_open ? static_cast<int>(summed) : 0;
  sum_ = sum;
  sum_t0_ns_ = sum_t0_ns;
  skip_through_ns_ = std::numeric_limits<int64_t>::min();
  distance_base_km_ = 0;
  drive_id_offset_ = next_drive_id;
  // A shorter window_h than the state was learned with: evict as CloseSegment() does.
  EvictBeyondWindow();
}

}  // namespace ndsid::stats
