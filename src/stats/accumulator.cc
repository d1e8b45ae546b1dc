#include "ndsid/stats/accumulator.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <type_traits>

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
    current_.has_yaw_rate = current_.has_yaw_rate && s.has_yaw_rate;
    current_.has_long_accel = current_.has_long_accel && s.has_long_accel;
    if (++summed_ == decimation_) {
      const float k = 1.0f / static_cast<float>(decimation_);
      if (current_.samples.empty()) current_.t0_ns = sum_t0_ns_;
      current_.samples.push_back({sum_.steer_rad * k, sum_.speed_mps * k, sum_.lat_accel_mps2 * k,
                                  sum_.yaw_rate_radps * k, sum_.long_accel_mps2 * k});
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
  for (auto& s : pending_segments_) window_.push_back(std::move(s));
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
  // Evict the oldest segments beyond the window (by accepted duration).
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

double Accumulator::window_hours() const {
  double s = 0;
  for (const auto& seg : window_) s += seg->duration_s();
  return s / 3600.0;
}

// ---- Persistence --------------------------------------------------------------------------

namespace {

constexpr char kAccumulatorTagV1[4] = {'A', 'C', 'C', '1'};  // without the open drive
constexpr char kAccumulatorTag[4] = {'A', 'C', 'C', '2'};    // + the open drive
constexpr uint64_t kMaxCount = uint64_t{1} << 32;  // no count in a plausible state comes near this

class ByteWriter {
 public:
  template <typename T>
  void Put(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    out_.append(reinterpret_cast<const char*>(&v), sizeof v);
  }
  void PutBlob(const std::string& s) {
    Put<uint64_t>(s.size());
    out_ += s;
  }
  std::string& str() { return out_; }

 private:
  std::string out_;
};

class ByteReader {
 public:
  explicit ByteReader(const std::string& in) : in_(in) {}
  template <typename T>
  T Get() {
    static_assert(std::is_trivially_copyable_v<T>);
    if (in_.size() - pos_ < sizeof(T)) throw Error("accumulator state: truncated");
    T v;
    std::memcpy(&v, in_.data() + pos_, sizeof v);
    pos_ += sizeof v;
    return v;
  }
  double Finite() {
    const double v = Get<double>();
    if (!std::isfinite(v)) throw Error("accumulator state: non-finite value");
    return v;
  }
  uint64_t Count() {
    const uint64_t n = Get<uint64_t>();
    if (n > kMaxCount || n > in_.size() - pos_ + 1) throw Error("accumulator state: implausible count");
    return n;
  }
  std::string Blob() {
    const uint64_t n = Count();
    if (in_.size() - pos_ < n) throw Error("accumulator state: truncated");
    std::string s = in_.substr(pos_, n);
    pos_ += n;
    return s;
  }
  // The format version, 1 or 2, from the tag.
  int Version() {
    char t[4];
    for (char& c : t) c = Get<char>();
    if (std::memcmp(t, kAccumulatorTag, 4) == 0) return 2;
    if (std::memcmp(t, kAccumulatorTagV1, 4) == 0) return 1;
    throw Error("accumulator state: wrong tag (not an accumulator state, or another version)");
  }
  bool done() const { return pos_ == in_.size(); }

 private:
  const std::string& in_;
  size_t pos_ = 0;
};

void CheckFinite(const RegressionStats& r) {
  bool ok = std::isfinite(r.yty()) && std::isfinite(r.n()) && r.n() >= 0;
  for (double v : r.xtx()) ok = ok && std::isfinite(v);
  for (double v : r.xty()) ok = ok && std::isfinite(v);
  if (!ok) throw Error("accumulator state: non-finite or negative steady-state statistics");
}

void CheckFinite(const Histogram2d& h) {
  for (double v : h.counts) {
    if (!std::isfinite(v) || v < 0) throw Error("accumulator state: non-finite or negative coverage count");
  }
}

void PutSegment(ByteWriter& w, const Segment& seg) {
  w.Put(seg.t0_ns);
  w.Put(seg.drive_id);
  w.Put(seg.dt_s);
  w.Put<uint8_t>(seg.has_yaw_rate);
  w.Put<uint8_t>(seg.has_long_accel);
  w.Put<uint64_t>(seg.samples.size());
  w.str().append(reinterpret_cast<const char*>(seg.samples.data()), seg.samples.size() * sizeof(SegmentSample));
}

std::shared_ptr<const Segment> GetSegment(ByteReader& r) {
  Segment seg;
  seg.t0_ns = r.Get<int64_t>();
  seg.drive_id = r.Get<int64_t>();
  seg.dt_s = r.Finite();
  seg.has_yaw_rate = r.Get<uint8_t>() != 0;
  seg.has_long_accel = r.Get<uint8_t>() != 0;
  seg.samples.resize(r.Count());
  if (!(seg.dt_s > 0) || seg.drive_id < 0) throw Error("accumulator state: implausible segment");
  for (SegmentSample& s : seg.samples) {
    s = r.Get<SegmentSample>();
    for (float v : {s.steer_rad, s.speed_mps, s.lat_accel_mps2, s.yaw_rate_radps, s.long_accel_mps2}) {
      if (!std::isfinite(v)) throw Error("accumulator state: non-finite segment sample");
    }
  }
  return std::make_shared<const Segment>(std::move(seg));
}

}  // namespace

std::string Accumulator::Serialize() const {
  const Accumulator& done = *this;
  ByteWriter w;
  for (char c : kAccumulatorTag) w.Put(c);
  w.Put(done.gated_s_);
  w.Put<uint64_t>(done.counters_.short_drive_samples);
  w.Put<uint64_t>(done.counters_.short_segment_samples);
  w.Put<uint64_t>(done.counters_.evicted_segments);
  w.PutBlob(done.steady_.Serialize());
  w.PutBlob(done.coverage_.Serialize());
  w.Put<uint64_t>(done.drives_.size());
  for (const DriveSummary& d : done.drives_) {
    w.Put(d.drive_id);
    w.Put(d.start_ns);
    w.Put(d.end_ns);
    w.Put(d.distance_km);
    w.Put(d.gated_s);
    w.Put<uint8_t>(d.used);
  }
  w.Put<uint64_t>(done.window_.size());
  for (const auto& seg : done.window_) PutSegment(w, *seg);
  // The drive in progress: open, used, and what it holds back while short of min_drive_km.
  const bool open = done.drive_open_ && !done.drives_.empty();
  w.Put<uint8_t>(open);
  if (open) {
    w.Put<uint8_t>(done.drive_used_);
    w.Put(done.pending_gated_s_);
    w.Put<uint64_t>(done.pending_samples_);
    w.PutBlob(done.pending_steady_.Serialize());
    w.PutBlob(done.pending_coverage_.Serialize());
    w.Put<uint64_t>(done.pending_segments_.size());
    for (const auto& seg : done.pending_segments_) PutSegment(w, *seg);
    // Its open segment, with the decimation's partial sum, so that a restart can go on with it.
    w.Put<uint8_t>(done.segment_open_);
    if (done.segment_open_) {
      PutSegment(w, done.current_);
      w.Put<int32_t>(done.summed_);
      w.Put(done.sum_);
      w.Put(done.sum_t0_ns_);
    }
  }
  return std::move(w.str());
}

void Accumulator::Restore(const std::string& bytes) {
  ByteReader r(bytes);
  const int version = r.Version();
  const double gated_s = r.Finite();
  if (gated_s < 0) throw Error("accumulator state: negative gated time");
  AccumulatorCounters counters;
  counters.short_drive_samples = r.Get<uint64_t>();
  counters.short_segment_samples = r.Get<uint64_t>();
  counters.evicted_segments = r.Get<uint64_t>();
  SteadyStateStats steady = SteadyStateStats::Deserialize(r.Blob());
  CheckFinite(steady.without_yaw());
  CheckFinite(steady.with_yaw());
  Coverage coverage = Coverage::Deserialize(r.Blob());
  CheckFinite(coverage.gg());
  CheckFinite(coverage.v_ay());

  std::vector<DriveSummary> drives(r.Count());
  int64_t next_drive_id = 0;
  for (DriveSummary& d : drives) {
    d.drive_id = r.Get<int64_t>();
    d.start_ns = r.Get<int64_t>();
    d.end_ns = r.Get<int64_t>();
    d.distance_km = r.Finite();
    d.gated_s = r.Finite();
    d.used = r.Get<uint8_t>() != 0;
    if (d.drive_id < 0 || d.end_ns < d.start_ns || d.distance_km < 0 || d.gated_s < 0) {
      throw Error("accumulator state: implausible drive summary");
    }
    next_drive_id = std::max(next_drive_id, d.drive_id + 1);
  }
  std::deque<std::shared_ptr<const Segment>> window;
  const size_t n_segments = r.Count();
  for (size_t i = 0; i < n_segments; ++i) {
    window.push_back(GetSegment(r));
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
  int32_t summed = 0;
  SegmentSample sum{};
  int64_t sum_t0_ns = 0;
  if (version >= 2) {
    open = r.Get<uint8_t>() != 0;
    if (open) {
      if (drives.empty()) throw Error("accumulator state: an open drive without its summary");
      used = r.Get<uint8_t>() != 0;
      pending_gated_s = r.Finite();
      pending_samples = r.Get<uint64_t>();
      if (pending_gated_s < 0 || pending_samples > kMaxCount) throw Error("accumulator state: implausible open drive");
      pending_steady = SteadyStateStats::Deserialize(r.Blob());
      CheckFinite(pending_steady.without_yaw());
      CheckFinite(pending_steady.with_yaw());
      pending_coverage = Coverage::Deserialize(r.Blob());
      CheckFinite(pending_coverage.gg());
      CheckFinite(pending_coverage.v_ay());
      const size_t n_pending = r.Count();
      for (size_t i = 0; i < n_pending; ++i) {
        pending_segments.push_back(GetSegment(r));
        if (pending_segments.back()->drive_id != drives.back().drive_id)
          throw Error("accumulator state: held-back segment of another drive");
      }
      if (used && (pending_samples != 0 || !pending_segments.empty()))
        throw Error("accumulator state: a used drive with held-back data");
      segment_open = r.Get<uint8_t>() != 0;
      if (segment_open) {
        current = *GetSegment(r);
        summed = r.Get<int32_t>();
        sum = r.Get<SegmentSample>();
        sum_t0_ns = r.Get<int64_t>();
        if (current.drive_id != drives.back().drive_id || summed < 0 || summed >= decimation_)
          throw Error("accumulator state: implausible open segment");
        for (float v : {sum.steer_rad, sum.speed_mps, sum.lat_accel_mps2, sum.yaw_rate_radps, sum.long_accel_mps2}) {
          if (!std::isfinite(v)) throw Error("accumulator state: non-finite open segment");
        }
      }
    }
  }
  if (!r.done()) throw Error("accumulator state: trailing bytes");

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
  summed_ = segment_open ? summed : 0;
  sum_ = sum;
  sum_t0_ns_ = sum_t0_ns;
  skip_through_ns_ = std::numeric_limits<int64_t>::min();
  distance_base_km_ = 0;
  drive_id_offset_ = next_drive_id;
  // A shorter window_h than the state was learned with: evict as CloseSegment() does.
  double total = window_hours() * 3600.0;
  while (!window_.empty() && total - window_.front()->duration_s() >= window_s_) {
    total -= window_.front()->duration_s();
    window_.pop_front();
    ++counters_.evicted_segments;
  }
}

}  // namespace ndsid::stats
