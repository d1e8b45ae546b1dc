// The configuration's signals section: each role's signal (or expression), unit, sign, timeout
// and latency, and the validity signals.
#include <algorithm>
#include <cctype>

#include "config_sections.h"

namespace ndsid::config {
namespace {

SignalRef ReadRef(const YamlReader& r) { return {r.String("message"), r.String("signal")}; }

// A role expression: its MESSAGE.SIGNAL names become the inputs, in order of appearance.
void ReadRoleExpression(const YamlReader& r, RoleSignal& s) {
  s.expr = r.String("expr");
  if (r.Has("message") || r.Has("signal")) r.Fail("expr", "give either expr or message + signal, not both");
  std::vector<std::string> names;
  const std::string& t = s.expr;
  for (size_t i = 0; i < t.size();) {
    const auto word = [&](size_t k) { return std::isalnum(static_cast<unsigned char>(t[k])) || t[k] == '_'; };
    if (!(std::isalpha(static_cast<unsigned char>(t[i])) || t[i] == '_') || (i > 0 && (word(i - 1) || t[i - 1] == '.'))) {
      ++i;
      continue;
    }
    size_t j = i;
    while (j < t.size() && (word(j) || (t[j] == '.' && j + 1 < t.size() && (std::isalpha(static_cast<unsigned char>(t[j + 1])) || t[j + 1] == '_'))))
      ++j;
    const std::string name = t.substr(i, j - i);
    const size_t dot = name.find('.');
    if (dot != std::string::npos && std::find(names.begin(), names.end(), name) == names.end()) {
      if (name.find('.', dot + 1) != std::string::npos) r.Fail("expr", "'" + name + "': a signal is MESSAGE.SIGNAL (one '.')");
      names.push_back(name);
      s.inputs.push_back({name.substr(0, dot), name.substr(dot + 1)});
    }
    i = j;
  }
  if (s.inputs.empty()) r.Fail("expr", "'" + s.expr + "' names no signal (write MESSAGE.SIGNAL)");
  try {
    s.expression = std::make_shared<const Expression>(Expression::Parse(s.expr, names));
  } catch (const ConfigError& e) {
    r.Fail("expr", e.what());
  }
  s.ref = s.inputs.front();
}

RoleSignal ReadRole(const YamlReader& parent, Role role) {
  const YamlReader r = parent.Child(RoleKey(role));
  RoleSignal s;
  if (r.Has("expr")) {
    ReadRoleExpression(r, s);
  } else {
    s.ref = ReadRef(r);
  }
  s.line = parent.Line(RoleKey(role));
  if (RoleIsFlag(role)) {
    s.active_values = r.Numbers("active_values", {1.0});
    s.timeout_s = Ranged(r, "timeout_s", 0.5, 1e-3, kMaxTimeoutS);
  } else {
    s.unit = r.String("unit");
    const double sign = r.Number("sign", 1.0);
    if (sign != 1.0 && sign != -1.0) r.Fail("sign", "must be 1 or -1");
    try {
      s.scale_to_si = sign * UnitToSi(role, s.unit);
    } catch (const ConfigError& e) {
      r.Fail("unit", e.what());
    }
    s.timeout_s = Ranged(r, "timeout_s", 0.1, 1e-3, kMaxTimeoutS);
    s.latency_s = r.Number("latency_s", 0.0);
    CheckRange(r, "latency_s", s.latency_s, -0.2, 0.5);
    if (role == Role::kLateralAcceleration && s.latency_s != 0.0) {
      r.Fail("latency_s", "the lateral acceleration is the time reference: give the other roles' latencies relative to it");
    }
    // Conditioning (sync/lowpass.h): 0 = none; the upper limit against the sync rate is checked
    // once sync is read (ParseConfig).
    s.lowpass_hz = Ranged(r, "lowpass_hz", 0.0, 0, 250);
  }
  r.Finish();
  return s;
}

void ReadValidity(const YamlReader& sig, Config& c) {
  const auto validity = sig.Raw("validity");
  if (!validity) return;
  if (!validity->IsSequence()) sig.FailAt(*validity, "validity", "expected a list");
  int idx = 0;
  for (const auto& item : *validity) {
    const YamlReader vr(item, sig.file(), "signals.validity[" + std::to_string(idx++) + "]");
    ValiditySignal v;
    v.ref = ReadRef(vr);
    v.valid_values = vr.Numbers("valid_values", {1.0});
    v.timeout_s = Ranged(vr, "timeout_s", 0.2, 1e-3, kMaxTimeoutS);
    v.line = item.Mark().line + 1;
    vr.Finish();
    c.validity.push_back(v);
  }
}

}  // namespace

void ReadSignals(const YamlReader& sig, Config& c) {
  for (int i = 0; i < kNumRoles; ++i) {
    const Role role = static_cast<Role>(i);
    if (sig.Has(RoleKey(role))) {
      c.roles[i] = ReadRole(sig, role);
    } else if (RoleIsRequired(role)) {
      sig.Fail(RoleKey(role), "missing required role");
    } else {
      sig.Raw(RoleKey(role));
    }
  }
  ReadValidity(sig, c);
  sig.Finish();
}

}  // namespace ndsid::config
