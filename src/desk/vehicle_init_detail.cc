#include "vehicle_init_detail.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <set>

#include <spdlog/fmt/fmt.h>
#include "ndsid/dbc/decoder.h"

namespace ndsid::desk::init_detail {

const std::string& BusData::BusOf(const std::string& message) const {
  static const std::string kNone;
  const auto it = message_bus.find(message);
  return it == message_bus.end() || it->second >= bus_names.size() ? kNone : bus_names[it->second];
}

int BusData::Find(const std::string& message, const std::string& signal) const {
  for (size_t i = 0; i < signals.size(); ++i)
    if (signals[i].message->name == message && signals[i].signal->name == signal) return static_cast<int>(i);
  return -1;
}

namespace {

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// "STEER_ANGLE" -> {steer, angle}; "SteeringWheelAngle" -> {steering, wheel, angle}.
std::vector<std::string> Tokens(const std::string& name) {
  std::vector<std::string> out;
  std::string cur;
  for (size_t i = 0; i < name.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(name[i]);
    // camelCase and the end of an acronym: "FLWheelSpd" -> {fl, wheel, spd}.
    const bool next_lower = i + 1 < name.size() && std::islower(static_cast<unsigned char>(name[i + 1]));
    const bool boundary = !cur.empty() && std::isupper(c) && i > 0 &&
                          (std::islower(static_cast<unsigned char>(name[i - 1])) ||
                           (next_lower && std::isupper(static_cast<unsigned char>(name[i - 1]))));
    if (!std::isalnum(c) || boundary) {
      if (!cur.empty()) out.push_back(Lower(cur));
      cur.clear();
      if (!std::isalnum(c)) continue;
    }
    cur += static_cast<char>(c);
  }
  if (!cur.empty()) out.push_back(Lower(cur));
  return out;
}

bool Any(const std::vector<std::string>& tokens, std::initializer_list<const char*> prefixes) {
  for (const auto& t : tokens)
    for (const char* p : prefixes)
      if (t.rfind(p, 0) == 0) return true;
  return false;
}
bool AnyExact(const std::vector<std::string>& tokens, std::initializer_list<const char*> words) {
  for (const auto& t : tokens)
    for (const char* w : words)
      if (t == w) return true;
  return false;
}
bool Contains(const std::string& low, std::initializer_list<const char*> parts) {
  for (const char* p : parts)
    if (low.find(p) != std::string::npos) return true;
  return false;
}

// 0 FL, 1 FR, 2 RL, 3 RR from a name's tokens: a corner code or a side and an axle word.
int CornerOf(const std::vector<std::string>& t) {
  static const std::pair<const char*, int> kCodes[] = {
      {"fl", 0}, {"lf", 0}, {"vl", 0}, {"lv", 0}, {"fr", 1}, {"rf", 1}, {"vr", 1}, {"rv", 1},
      {"rl", 2}, {"lr", 2}, {"hl", 2}, {"lh", 2}, {"rr", 3}, {"hr", 3}, {"rh", 3}};
  for (const auto& [code, corner] : kCodes)
    if (AnyExact(t, {code})) return corner;
  const bool front = AnyExact(t, {"front", "vorne", "vorn", "vo", "frt"});
  const bool rear = AnyExact(t, {"rear", "hinten", "hi"});
  const bool left = AnyExact(t, {"left", "links", "li", "lft"});
  const bool right = AnyExact(t, {"right", "rechts", "re", "rgt"});
  return front != rear && left != right ? (rear ? 2 : 0) + (right ? 1 : 0) : -1;
}

}  // namespace

int WheelCorner(const dbc::Message& m, const dbc::Signal& s) {
  const int own = CornerOf(Tokens(s.name));
  return own >= 0 ? own : CornerOf(Tokens(m.name));
}

bool IsRpmUnit(const std::string& unit) {
  const std::string u = Lower(unit);
  for (const char* a : {"rpm", "1/min", "u/min", "min-1", "min^-1", "1/mn", "r/min", "rev/min", "upm", "tr/min"})
    if (u == a) return true;
  return false;
}

namespace {

const std::initializer_list<const char*> kNeverRole = {
    "stat", "diag", "qbit", "valid", "fault", "counter", "checksum", "crc", "cmd", "req", "command", "target",
    "desired", "limit", "lim", "offset", "vz", "sign", "init", "error", "override", "max", "min", "set", "alive"};

// How much the names say the signal is `kind` (0: not a candidate).
int BaseNameScore(RoleKind kind, const dbc::Message& m, const dbc::Signal& s) {
  const auto t = Tokens(s.name);
  const auto mt = Tokens(m.name);
  const std::string low = Lower(s.name);
  if (AnyExact(t, kNeverRole) || Any(t, {"stat", "checksum", "counter", "qbit"})) return 0;
  switch (kind) {
    case RoleKind::kSteer: {
      if (Any(t, {"rate", "speed", "veloc", "torque", "moment", "lka", "fraction", "frac"}) || Contains(low, {"geschw", "moment"})) return 0;
      const bool steer = Any(t, {"steer", "lenk"}) || AnyExact(t, {"sas", "swa", "lws"}) || Contains(low, {"lenkrad"});
      const bool msg = Any(mt, {"steer", "lenk"}) || AnyExact(mt, {"sas", "lwi", "lws"});
      const bool angle = Any(t, {"ang", "winkel"}) || Contains(low, {"winkel"});
      const bool unit = MatchUnit(SteerUnits(), s.unit) >= 0;
      if (!((steer || msg) && (angle || unit))) return 0;
      return 2 * steer + msg + 2 * angle + unit + Any(mt, {"sensor"});
    }
    case RoleKind::kSpeed: {
      // Named a speed, or only in a speed unit (VW's ESP_v_Signal in Unit_KiloMeterPerHour).
      const bool named = Any(t, {"speed", "spd", "veloc", "geschw"}) || Contains(low, {"geschw"});
      const bool unit = MatchUnit(SpeedUnits(), s.unit) >= 0;
      if (!named && !unit) return 0;
      if (CornerOf(t) >= 0) return 0;  // one wheel's speed
      if (Any(t, {"wheel", "whl", "rad", "engine", "eng", "rpm", "cruise", "hud", "fan", "wiper", "steer", "rate",
                  "accel", "rel", "obj", "nav", "gear", "rough", "disp", "left", "right", "lenk", "sound", "acc",
                  "angez", "anzeige", "wunsch", "soll", "tempo", "lim"}) ||
          Any(mt, {"wheel", "whl", "acc", "cruise", "hud", "nav"}))
        return 0;
      return (named ? 3 : 1) + Any(t, {"vehicle", "veh", "car", "xmission", "fzg"}) + unit;
    }
    case RoleKind::kWheelSpeed: {
      // A corner, and a speed: by its unit (km/h, m/s, mph, or 1/min: a rolling radius is fitted
      // later) or by its name. The data decide which of them follow the vehicle speed. Without a
      // corner in the names, any speed-like signal is a weak candidate: the wheels among them are
      // told by their left-right deviation against the yaw rate (ChooseWheels).
      const bool corner = WheelCorner(m, s) >= 0;
      const bool wheel = Any(t, {"wheel", "whl", "rad", "rd"}) || Any(mt, {"wheel", "whl", "rad"});
      const bool named = Any(t, {"speed", "spd", "veloc", "rpm"}) || Contains(low, {"geschw", "drehzahl"}) ||
                         Any(mt, {"speed", "spd"}) || Contains(Lower(m.name), {"geschw", "drehzahl"});
      const bool unit = MatchUnit(SpeedUnits(), s.unit) >= 0 || IsRpmUnit(s.unit);
      if (Any(t, {"press", "druck", "temp", "torque", "moment", "slip", "schlupf", "brake", "brems", "puls", "impuls",
                  "tick", "edge", "flank", "dist", "weg", "height", "hoehe", "level", "niveau"}))
        return 0;
      if (!corner) return unit || (wheel && named) ? 1 : 0;
      return unit || named ? 2 + wheel + (unit && named) : 0;
    }
    case RoleKind::kLatAccel: {
      if (Any(t, {"long", "ref", "obj", "pos", "jerk", "gps"})) return 0;
      const bool lat = AnyExact(t, {"lat", "lateral", "y", "ay", "quer"}) || Contains(low, {"quer", "accel_y", "acc_y", "laty", "lateralacc"});
      const bool acc = Any(t, {"acc", "ac", "beschl"}) || AnyExact(t, {"ay"}) || Contains(low, {"beschl"});
      if (!(lat && acc)) return 0;
      return 3 + (MatchUnit(AccelUnits(), s.unit) >= 0);
    }
    case RoleKind::kYawRate: {
      if (!Contains(low, {"yaw", "gier"})) return 0;
      if (Any(t, {"acc", "ang", "cal"})) return 0;
      return 3 + (MatchUnit(YawUnits(), s.unit) >= 0) + Any(t, {"rate", "rt"});
    }
    case RoleKind::kLongAccel: {
      if (Any(t, {"lat", "ref", "obj", "pos", "jerk", "gps", "pedal", "net"})) return 0;
      const bool lon = AnyExact(t, {"long", "longitudinal", "x", "ax", "laengs"}) || Contains(low, {"laengs", "accel_x", "acc_x"});
      const bool acc = Any(t, {"acc", "beschl"}) || AnyExact(t, {"ax"}) || Contains(low, {"beschl"});
      if (!(lon && acc)) return 0;
      return 3 + (MatchUnit(AccelUnits(), s.unit) >= 0);
    }
  }
  return 0;
}

// The DBC's other hints, for a signal the names already made a candidate: +1 when its comment
// names the quantity, +1 when its declared range is plausible for it (in SI, where the DBC's
// unit says which; opendbc's [0|0] ranges say nothing).
int NameScore(RoleKind kind, const dbc::Message& m, const dbc::Signal& s) {
  const int base = BaseNameScore(kind, m, s);
  if (base <= 0) return 0;
  const std::string c = Lower(s.comment);
  const double range = std::max(std::fabs(s.minimum), std::fabs(s.maximum));
  auto in_si = [&](const std::vector<UnitOption>& units) {
    const int u = MatchUnit(units, s.unit);
    return u < 0 ? NAN : range * units[static_cast<size_t>(u)].to_si;
  };
  int hint = 0;
  switch (kind) {
    case RoleKind::kSteer: {
      hint += Contains(c, {"steering", "lenkrad", "steer"}) && Contains(c, {"angle", "winkel"});
      const double r = in_si(SteerUnits());
      hint += r >= 5.0 && r <= 60.0;  // +-290..3400 deg
      break;
    }
    case RoleKind::kSpeed: {
      hint += Contains(c, {"vehicle speed", "fahrzeuggeschw", "velocity"});
      const double r = in_si(SpeedUnits());
      hint += r >= 40.0 && r <= 200.0;
      break;
    }
    case RoleKind::kLatAccel: {
      hint += Contains(c, {"lateral acc", "querbeschl"});
      const double r = in_si(AccelUnits());
      hint += r >= 8.0 && r <= 40.0;
      break;
    }
    case RoleKind::kYawRate: {
      hint += Contains(c, {"yaw rate", "gierrate", "giergeschw"});
      const double r = in_si(YawUnits());
      hint += r >= 0.7 && r <= 10.0;  // 40..570 deg/s
      break;
    }
    case RoleKind::kLongAccel: {
      hint += Contains(c, {"longitudinal acc", "laengsbeschl"});
      const double r = in_si(AccelUnits());
      hint += r >= 8.0 && r <= 40.0;
      break;
    }
    case RoleKind::kWheelSpeed: break;
  }
  return base + hint;
}

std::string Ref(const SignalSeries& s) { return s.message->name + "." + s.signal->name; }

// Coarse + fine pair (the RAV4's STEER_ANGLE in 1.5 deg steps + STEER_FRACTION): a varying signal
// of the same frames named as a fraction, or whose range is about one step of the coarse one.
// Both S + F and S - F are returned as candidates; the physics fit chooses among them and S alone.
std::vector<Source> FinePairs(const BusData& data, const Source& coarse) {
  std::vector<Source> out;
  const SignalSeries& c = data.signals[static_cast<size_t>(coarse.terms[0])];
  const double step = std::fabs(c.signal->factor);
  if (step < 0.2) return out;
  for (size_t j = 0; j < data.signals.size(); ++j) {
    const SignalSeries& f = data.signals[j];
    if (&f == &c || f.message != c.message || !f.varies || f.v.size() != c.v.size()) continue;
    const std::string low = Lower(f.signal->name);
    const double range = std::max(std::fabs(f.min), std::fabs(f.max));
    const bool named = Contains(low, {"fraction", "frac", "fine", "fein"});
    if (!named && !(range >= 0.2 * step && range <= 1.5 * step && std::fabs(f.signal->factor) < step)) continue;
    if (Contains(low, {"rate", "counter", "checksum", "torque"})) continue;
    for (const bool add : {true, false}) {
      Source src = coarse;
      src.terms.push_back(static_cast<int>(j));
      src.combine = add ? Source::Combine::kSum : Source::Combine::kDifference;
      src.expression = Ref(c) + (add ? " + " : " - ") + Ref(f);
      src.pair_evidence = fmt::format("{} (|value| <= {:.3g} {}, {}within one {:.3g} {} step of {}) {}", f.signal->name,
                                      range, f.signal->unit, named ? "named as the fine part, " : "", step, c.signal->unit,
                                      c.signal->name, add ? "added" : "subtracted");
      src.name_score += 2;
      out.push_back(std::move(src));
    }
  }
  return out;
}

// Sign + magnitude (VW's LWI_Lenkradwinkel + LWI_VZ_Lenkradwinkel): a never-negative signal and
// a varying 1-bit signal of the same message named as its sign.
bool CombineSign(const BusData& data, Source& src) {
  const SignalSeries& m = data.signals[static_cast<size_t>(src.terms[0])];
  if (m.min < 0) return false;
  for (size_t j = 0; j < data.signals.size(); ++j) {
    const SignalSeries& b = data.signals[j];
    if (b.message != m.message || b.signal->length != 1 || b.v.size() != m.v.size() || b.min == b.max) continue;
    const auto t = Tokens(b.signal->name);
    if (!(AnyExact(t, {"vz", "sign", "sgn", "vorzeichen"}))) continue;
    src.terms.push_back(static_cast<int>(j));
    src.combine = Source::Combine::kSignMagnitude;
    src.expression = Ref(m) + " * (1 - 2 * " + Ref(b) + ")";
    src.pair_evidence = fmt::format("{} is never negative and {} (1 bit, varying) is its sign", m.signal->name, b.signal->name);
    src.name_score += 2;
    return true;
  }
  return false;
}

}  // namespace

BusData CollectSignals(const dbc::Database& db, can::FrameLog& log, const std::string& bus, uint64_t max_frames,
                       uint64_t& frames, bool& truncated) {
  // Only the messages with a signal named like a role (all their signals: a fine or sign partner
  // may have any name): the decoded log is held in memory.
  std::vector<dbc::SignalSelector> selection;
  for (const auto& m : db.messages) {
    bool any = false;
    for (const auto& sig : m.signals)
      for (RoleKind k : {RoleKind::kSteer, RoleKind::kSpeed, RoleKind::kLatAccel, RoleKind::kYawRate,
                         RoleKind::kLongAccel, RoleKind::kWheelSpeed})
        any = any || NameScore(k, m, sig) > 0;
    if (any)
      for (const auto& sig : m.signals) selection.push_back({m.name, sig.name});
  }
  if (selection.empty()) return {};
  const dbc::Decoder decoder(db, selection);
  std::unordered_map<uint64_t, SignalSeries> by_key;  // (signal index << 16 | bus)
  std::vector<can::CanFrame> buf(512);
  std::vector<dbc::DecodedValue> out(std::max<size_t>(1, decoder.max_signals_per_message()));
  bool first = true;
  int64_t t0_ns = 0, t1_ns = 0;
  frames = 0;
  truncated = false;
  for (;;) {
    const can::ReadResult r = log.Read(buf, 0);
    for (size_t i = 0; i < r.count && !truncated; ++i) {
      if (frames >= max_frames) {
        truncated = true;
        break;
      }
      const can::CanFrame& f = buf[i];
      ++frames;
      if (!bus.empty() && (f.bus >= log.bus_names().size() || log.bus_names()[f.bus] != bus)) continue;
      size_t count = 0;
      decoder.Decode(f, out, count);
      if (count == 0) continue;
      if (first) t0_ns = f.timestamp_ns, first = false;
      t1_ns = std::max(t1_ns, f.timestamp_ns);
      const double t = static_cast<double>(f.timestamp_ns - t0_ns) * 1e-9;
      for (size_t k = 0; k < count; ++k) {
        const uint64_t key = (static_cast<uint64_t>(out[k].signal_index) << 16) | f.bus;
        SignalSeries& s = by_key[key];
        if (s.signal == nullptr) {
          const auto& sel = decoder.signals()[static_cast<size_t>(out[k].signal_index)];
          s.message = sel.message, s.signal = sel.signal, s.bus = f.bus;
        }
        s.t.push_back(t);
        s.v.push_back(out[k].value);
      }
    }
    if (r.state == can::SourceState::kEnd || truncated) break;
  }
  BusData data;
  data.bus_names = log.bus_names();
  data.t1 = static_cast<double>(t1_ns - t0_ns) * 1e-9;
  // Each message on the bus where it has the most frames.
  std::map<std::string, std::pair<size_t, uint16_t>> most;
  for (const auto& [key, s] : by_key) {
    auto& m = most[s.message->name];
    if (s.t.size() > m.first || (s.t.size() == m.first && s.bus < m.second)) m = {s.t.size(), s.bus};
  }
  for (const auto& [name, m] : most) data.message_bus[name] = m.second;
  for (auto& [key, s] : by_key) {
    if (data.message_bus[s.message->name] != s.bus) continue;
    std::vector<double> dt;
    for (size_t i = 1; i < s.t.size(); i += std::max<size_t>(1, s.t.size() / 2000)) dt.push_back(s.t[i] - s.t[i - 1]);
    if (!dt.empty()) {
      std::nth_element(dt.begin(), dt.begin() + static_cast<std::ptrdiff_t>(dt.size() / 2), dt.end());
      s.period_s = dt[dt.size() / 2];
    }
    const auto [lo, hi] = std::minmax_element(s.v.begin(), s.v.end());
    s.min = *lo, s.max = *hi;
    std::set<double> distinct;
    for (size_t i = 0; i < s.v.size() && distinct.size() < 3; ++i) distinct.insert(s.v[i]);
    s.varies = distinct.size() >= 3;
    data.signals.push_back(std::move(s));
  }
  // Deterministic order (the map above is unordered): DBC order.
  std::sort(data.signals.begin(), data.signals.end(), [](const SignalSeries& a, const SignalSeries& b) {
    return a.message->line != b.message->line ? a.message->line < b.message->line : a.signal->line < b.signal->line;
  });
  return data;
}

std::vector<Source> Candidates(const BusData& data, RoleKind kind, size_t top) {
  std::vector<Source> out;
  for (size_t i = 0; i < data.signals.size(); ++i) {
    const SignalSeries& s = data.signals[i];
    if (!s.varies || s.signal->mux_role == dbc::MuxRole::kMultiplexor) continue;
    const int score = NameScore(kind, *s.message, *s.signal);
    if (score <= 0) continue;
    Source src;
    src.terms = {static_cast<int>(i)};
    src.expression = Ref(s);
    src.unit = s.signal->unit;
    src.comment = s.signal->comment;
    src.name_score = score;
    if (kind == RoleKind::kWheelSpeed) src.corner = WheelCorner(*s.message, *s.signal);
    if (kind == RoleKind::kSteer || kind == RoleKind::kYawRate || kind == RoleKind::kLatAccel) CombineSign(data, src);
    if (kind == RoleKind::kSteer && s.signal->mux_role == dbc::MuxRole::kNone && src.terms.size() == 1)
      for (auto& pair : FinePairs(data, src)) out.push_back(std::move(pair));
    out.push_back(std::move(src));
  }
  std::stable_sort(out.begin(), out.end(), [](const Source& a, const Source& b) { return a.name_score > b.name_score; });
  if (out.size() > top) out.resize(top);
  return out;
}

void SetSource(RoleProposal& p, const Source& s, const BusData& data) {
  const SignalSeries& first = data.signals[static_cast<size_t>(s.terms[0])];
  p.message = first.message->name;
  p.signal = first.signal->name;
  p.expression = s.expression;
  p.multi_signal = s.terms.size() > 1;
  double period = first.period_s;
  for (int t : s.terms) period = std::max(period, data.signals[static_cast<size_t>(t)].period_s);
  p.period_s = period;
  // 10 periods rounded up to 0.05 s (2 % allowed for jitter in the measured period), at least 0.1 s.
  p.timeout_s = std::max(0.1, std::ceil(10.0 * period * 0.98 * 20.0) / 20.0);
}

const std::vector<UnitOption>& SpeedUnits() {
  static const std::vector<UnitOption> u = {{"km/h", 1.0 / 3.6, {"km/h", "kph", "kmh", "km/hr", "unit_kilometerperhour"}},
                                            {"m/s", 1.0, {"m/s", "mps", "unit_meterpersecond"}},
                                            {"mph", 0.44704, {"mph", "unit_milesperhour"}}};
  return u;
}
const std::vector<UnitOption>& YawUnits() {
  static const std::vector<UnitOption> u = {
      {"deg/s", M_PI / 180.0, {"deg/s", "deg/sec", "°/s", "degree/s", "degrees/s", "grad/s", "dps", "unit_degreofarcpersecon"}},
      {"rad/s", 1.0, {"rad/s", "rad/sec"}}};
  return u;
}
const std::vector<UnitOption>& AccelUnits() {
  static const std::vector<UnitOption> u = {
      {"m/s^2", 1.0, {"m/s^2", "m/s2", "m/s²", "m/s/s", "mps2", "unit_meterpersecondsquar", "unit_meterpersecondsquared", "unit_meterperseconsquar"}},
      {"g", 9.80665, {"g", "unit_forceofgravi", "unit_forceofgravity"}}};
  return u;
}
const std::vector<UnitOption>& SteerUnits() {
  static const std::vector<UnitOption> u = {{"deg", M_PI / 180.0, {"deg", "°", "degree", "degrees", "grad", "unit_degreofarc"}},
                                            {"rad", 1.0, {"rad", "radian", "radians"}}};
  return u;
}

int MatchUnit(const std::vector<UnitOption>& options, const std::string& dbc_unit) {
  const std::string u = Lower(dbc_unit);
  for (size_t i = 0; i < options.size(); ++i)
    for (const auto& a : options[i].aliases)
      if (u == a) return static_cast<int>(i);
  return -1;
}

int CommentDirection(const std::string& comment) {
  std::string low = Lower(comment);
  bool left = false, right = false;
  for (const char* ccw : {"counter-clockwise", "counterclockwise", "anti-clockwise", "anticlockwise", "ccw"}) {
    for (size_t p; (p = low.find(ccw)) != std::string::npos;) {
      left = true;
      low.erase(p, std::string(ccw).size());
    }
  }
  for (const char* ccw : {"gegen den uhrzeigersinn", "gegen uhrzeigersinn", "entgegen dem uhrzeigersinn", "gegenuhrzeigersinn"}) {
    for (size_t p; (p = low.find(ccw)) != std::string::npos;) {
      left = true;
      low.erase(p, std::string(ccw).size());
    }
  }
  if (Contains(low, {"clockwise", "uhrzeigersinn"})) right = true;
  for (const auto& t : Tokens(low)) {
    if (t == "left" || t == "links") left = true;
    if (t == "right" || t == "rechts") right = true;
  }
  return left == right ? 0 : (left ? 1 : -1);
}

}  // namespace ndsid::desk::init_detail
