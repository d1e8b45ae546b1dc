// Private to `ndsid init` (vehicle_init.cc): the decoded bus, candidates by name, the 20 Hz grid.
#pragma once

#include <cmath>
#include <cstdint>
#include <map>
#include <string>
#include <unordered_map>
#include <vector>

#include "ndsid/can/frame_log.h"
#include "ndsid/dbc/database.h"
#include "vehicle_init.h"

namespace ndsid::desk::init_detail {

// Every value of one signal on the bus it was seen most on.
struct SignalSeries {
  const dbc::Message* message = nullptr;
  const dbc::Signal* signal = nullptr;
  uint16_t bus = 0;
  std::vector<double> t;  // s since the first frame
  std::vector<double> v;  // physical value (DBC factor and offset applied)
  double period_s = 0;    // median spacing
  double min = 0, max = 0;
  bool varies = false;    // at least three distinct values
};

struct BusData {
  std::vector<SignalSeries> signals;
  std::vector<std::string> bus_names;
  std::map<std::string, uint16_t> message_bus;  // message name -> bus index used
  double t0 = 0, t1 = 0;                        // s, relative to the first frame (t0 = 0)
  const std::string& BusOf(const std::string& message) const;
  int Find(const std::string& message, const std::string& signal) const;  // -1 if absent
};

// Decodes the log (only `bus` if not empty) up to `max_frames` frames. Counts the frames read
// into `frames`; `truncated` when it stopped at the limit.
BusData CollectSignals(const dbc::Database& db, can::FrameLog& log, const std::string& bus, uint64_t max_frames,
                       uint64_t& frames, bool& truncated);

enum class RoleKind { kSteer, kSpeed, kLatAccel, kYawRate, kLongAccel, kWheelSpeed };

// The corner a wheel signal's name (or its message's) gives: 0 front left, 1 front right, 2 rear
// left, 3 rear right (FL, VL, LF, "links vorne", "FrontLeft" ...); -1 none.
int WheelCorner(const dbc::Message& m, const dbc::Signal& s);
// A rotational speed's unit: rpm, 1/min, U/min, min^-1 ...
bool IsRpmUnit(const std::string& unit);

// A role candidate: one signal, or several of one message combined.
struct Source {
  enum class Combine { kSingle, kSum, kDifference, kSignMagnitude };
  std::vector<int> terms;  // indices into BusData::signals
  Combine combine = Combine::kSingle;
  std::string expression;  // MESSAGE.SIGNAL, or the role expression
  std::string unit;        // DBC unit of the first term
  std::string comment;     // DBC comment of the first term (and its message)
  int name_score = 0;
  std::string pair_evidence;  // why several signals were combined
  int corner = -1;            // wheel speeds: WheelCorner
};

// Varying signals named like `kind`, best names first, at most `top`; coarse+fine and
// sign+magnitude pairs of one message are combined.
std::vector<Source> Candidates(const BusData& data, RoleKind kind, size_t top);

void SetSource(RoleProposal& p, const Source& s, const BusData& data);

// Onto a fixed grid: each point the mean of the samples since the previous point, else the last
// sample held; NaN where that is stale (older than max(0.5 s, 5 periods)) or absent; then a
// centred 1 s moving average (NaN if any value in it is).
class Grid {
 public:
  Grid(const BusData& data, double rate_hz);
  const std::vector<double>& Of(const Source& s);
  size_t size() const { return n_; }

 private:
  const std::vector<double>& OfSignal(int index);
  const BusData& data_;
  double rate_hz_;
  size_t n_;
  std::unordered_map<int, std::vector<double>> signals_;
  std::map<std::string, std::vector<double>> sources_;
};

struct UnitOption {
  const char* name;  // as the config writes it
  double to_si;
  std::vector<std::string> aliases;  // lower-case DBC spellings
};
const std::vector<UnitOption>& SpeedUnits();
const std::vector<UnitOption>& YawUnits();
const std::vector<UnitOption>& AccelUnits();
const std::vector<UnitOption>& SteerUnits();
int MatchUnit(const std::vector<UnitOption>& options, const std::string& dbc_unit);  // -1 unknown

inline constexpr double kGrid_hz = 20.0;
inline constexpr double kCharSpeed_mps = 20.0;  // v_ch assumed in the steering fits (EG ~ 2..4 deg/g)

struct Fit {
  double gain = 0, intercept = 0, corr = 0, gain_se = 0;
  size_t n = 0;
};
// Least squares y = gain x + intercept over the pairs where both are finite (n < 20: no fit).
Fit LinearFit(const std::vector<double>& x, const std::vector<double>& y);
double Percentile(std::vector<double> v, double q);  // NaN-free quantile, NaN if none
std::vector<double> Abs(std::vector<double> v);
// 0.9 on the option the DBC's unit string names (the rest share 0.1), else uniform.
std::vector<double> UnitPrior(const std::vector<UnitOption>& options, const std::string& dbc_unit);
inline double Gauss(double z) { return std::exp(-0.5 * z * z); }
std::string Pct(double p);

// The fallback for a bus without a yaw rate: a_y = v^2 d_sw / (is l (1 + v^2/v_ch^2)) picks
// (speed, a_y, steering) and their units from a plausible steer ratio; the absolute sign from
// the steering's comment or assumed. Fills those three roles of `result` (indexed by Role) and
// returns the speed in m/s on the grid, or an empty vector when nothing fits.
std::vector<double> ProposeWithoutYawRate(const BusData& data, Grid& grid, const std::vector<Source>& speed,
                                          const std::vector<Source>& lat, const std::vector<Source>& steer,
                                          const InitOptions& options, InitResult& result);

// Step 2, the steering, by the kinematic relation: the path's curvature kappa = r / v follows
// d_sw: kappa (1 + v^2/v_ch^2) = g d_sw with g = 1 / (is l), over every moving sample (v > 3 m/s,
// at any lateral acceleration: low speeds with large angles count), both sides median-filtered
// over 0.5 s. `yaw` times yaw_to_iso is the yaw rate in rad/s, ISO 8855; v_si the speed [m/s]
// on the grid. Fills result's steering role.
void ProposeSteering(const BusData& data, Grid& grid, const Source& yaw, double yaw_to_iso, const std::vector<double>& v_si,
                     const std::vector<Source>& steer, const InitOptions& options, InitResult& result);

// A running median over `width` samples (odd), NaN where more than half of them are NaN.
std::vector<double> MedianFilter(const std::vector<double>& x, size_t width);

inline constexpr double kSteerMoving_mps = 3.0;  // the steering fits' samples are above this speed

// Step 3, a_x = dv/dt from the speed v_si [m/s] on the grid (empty: not confirmed). Fills
// result's longitudinal-acceleration role.
void ProposeLongitudinal(const BusData& data, Grid& grid, const std::vector<double>& v_si, const std::vector<Source>& lon,
                         InitResult& result);

// The wheel speeds by physics: per corner the candidate that follows the vehicle speed best,
// kept when its correlation while moving is above 0.95 (at least two corners, one kind of unit);
// without two named corners, and given the yaw rate's candidate, the signals whose deviation from
// the vehicle speed follows the yaw rate with both signs (left and right wheels).
struct WheelChoice {
  std::vector<Source> wheels;  // the kept ones (FL FR RL RR order where named)
  std::vector<double> corr;    // each one's correlation with the vehicle speed
  bool rpm = false;            // rotational speeds (1/min): their scale is a rolling radius
  double ratio = NAN;          // vehicle speed / the wheels' mean, both in bus units (median while moving)
  double factor = NAN;         // the speed's unit factor to SI that the wheels' DBC speed unit implies
  std::string text;            // the evidence ("" when no wheels were kept)
};
WheelChoice ChooseWheels(Grid& grid, const std::vector<Source>& candidates, const Source& speed, double v99,
                         const Source* yaw);

// The optional wheel_speed role: the kept wheels' mean, its scale regressed on the vehicle speed
// v_si [m/s] on the grid (a unit, or a factor and the speed's unit: 1/min with a rolling radius).
void ProposeWheelSpeed(const BusData& data, Grid& grid, const WheelChoice& wheels, const std::vector<double>& v_si,
                       InitResult& result);

// The std [SI] of a source's raw samples about their centred 0.5 s moving mean, while the speed
// v_si on the grid is above 3 m/s (to_si: its unit's factor); NaN with fewer than 200 samples.
double HighFrequencyNoise(const BusData& data, const Source& s, double to_si, const std::vector<double>& v_si);

// Conditioning: the found a_y (and yaw rate) get lowpass_hz 5 when their noise is above 0.5 m/s^2
// (the yaw rate: 0.5 m/s^2 / 15 m/s), and the measured noise as evidence either way.
void ProposeConditioning(const BusData& data, const std::vector<Source>& lat, const std::vector<Source>& yaw,
                         const std::vector<double>& v_si, InitResult& result);

// The proposal of role r (result.roles is indexed by Role for the roles up to a_x).
inline RoleProposal& RoleOf(InitResult& result, config::Role r) { return result.roles[static_cast<size_t>(r)]; }

// +1 when a DBC comment says positive to the left (counter-clockwise), -1 to the right, else 0.
int CommentDirection(const std::string& comment);

}  // namespace ndsid::desk::init_detail
