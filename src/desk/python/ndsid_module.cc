// The `ndsid` Python package's compiled core (pybind11): the desk's C++ library called in
// process. Values cross as the project's JSON documents (the learned-state codec,
// docs/state-format.md) or as numpy columns; src/desk/python/ndsid/__init__.py turns them into
// dicts and pandas DataFrames (docs/python.md).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "command_registry.h"
#include "model_report.h"
#include "ndsid/can/frame_log.h"
#include "ndsid/common/error.h"
#include "ndsid/config/config.h"
#include "ndsid/config/truth_file.h"
#include "ndsid/dbc/dbc_parser.h"
#include "ndsid/dbc/decoder.h"
#include "ndsid/identify/result_codec.h"
#include "ndsid/model/single_track.h"
#include "ndsid/pipeline/estimate_codec.h"
#include "ndsid/pipeline/log_reduction.h"
#include "fleet_reduce.h"
#include "replay_document.h"
#include "replay_runner.h"

namespace py = pybind11;

namespace ndsid::desk {
namespace {

template <typename T>
py::array_t<T> Column(std::vector<T>&& v) {
  auto* heap = new std::vector<T>(std::move(v));
  py::capsule owner(heap, [](void* p) { delete static_cast<std::vector<T>*>(p); });
  return py::array_t<T>({heap->size()}, {sizeof(T)}, heap->data(), owner);
}

std::string LoadConfigJson(const std::string& path) {
  const config::Config c = config::LoadConfig(path);
  nlohmann::json j;
  j["path"] = c.path;
  j["vehicle"] = {{"name", c.vehicle.name}, {"wheelbase_m", c.vehicle.wheelbase_m}, {"mass_kg", c.vehicle.mass_kg}};
  j["dbc"] = c.dbc;
  j["effects"] = c.model_effects;
  j["outputs"] = c.identification.yaw_rate_output ? std::vector<std::string>{"a_y", "yaw_rate"} : std::vector<std::string>{"a_y"};
  j["logs"] = c.source.logs;
  j["report_dir"] = c.report_dir;
  j["state_dir"] = c.state_dir;
  j["window_h"] = c.identification.window_h;
  j["parameters"] = nlohmann::json::object();
  for (int i = 0; i < model::kNumParams; ++i) {
    const config::ParameterSpec& ps = c.identification.params[static_cast<size_t>(i)];
    j["parameters"][model::kParamNames[i]] = {{"min", ps.lower}, {"max", ps.upper}, {"initial", ps.initial}, {"fixed", ps.fixed}};
  }
  j["priors"] = nlohmann::json::object();
  for (const config::ParameterPrior& pr : c.identification.priors) j["priors"][pr.name] = {{"value", pr.value}, {"sd", pr.sd}};
  j["roles"] = nlohmann::json::object();
  for (int i = 0; i < config::kNumRoles; ++i) {
    const auto& r = c.roles[static_cast<size_t>(i)];
    if (!r) continue;
    j["roles"][config::RoleKey(static_cast<config::Role>(i))] = {
        {"message", r->ref.message}, {"signal", r->ref.signal}, {"expr", r->expr}, {"unit", r->unit},
        {"scale_to_si", r->scale_to_si}, {"latency_s", r->latency_s}};
  }
  return j.dump();
}

// Every decoded value of a log: time, message, signal and value columns (codes into `names`).
py::dict Decode(const std::string& log_path, const std::string& dbc_path, const std::string& bus) {
  const dbc::Database db = dbc::ParseDbcFile(dbc_path);
  const dbc::Decoder decoder(db, {});
  const std::unique_ptr<can::FrameLog> log = can::OpenFrameLog(log_path);
  std::vector<double> t;
  std::vector<int32_t> signal;
  std::vector<double> value;
  {
    py::gil_scoped_release unlocked;
    std::vector<can::CanFrame> frames(512);
    std::vector<dbc::DecodedValue> out(decoder.max_signals_per_message());
    for (;;) {
      const can::ReadResult r = log->Read(frames, 0);
      for (size_t i = 0; i < r.count; ++i) {
        const can::CanFrame& f = frames[i];
        if (!bus.empty() && (f.bus >= log->bus_names().size() || log->bus_names()[f.bus] != bus)) continue;
        size_t count = 0;
        decoder.Decode(f, out, count);
        for (size_t k = 0; k < count; ++k) {
          t.push_back(static_cast<double>(f.timestamp_ns) * 1e-9);
          signal.push_back(out[k].signal_index);
          value.push_back(out[k].value);
        }
      }
      if (r.state == can::SourceState::kEnd) break;
    }
  }
  if (!log->io_error().empty()) throw Error(log_path + ": not read to its end: " + log->io_error());
  std::vector<std::string> messages, signals;
  for (const auto& sel : decoder.signals()) {
    messages.push_back(sel.message->name);
    signals.push_back(sel.signal->name);
  }
  py::dict d;
  d["t_s"] = Column(std::move(t));
  d["code"] = Column(std::move(signal));
  d["value"] = Column(std::move(value));
  d["messages"] = messages;
  d["signals"] = signals;
  d["frames"] = log->counters().frames;
  d["malformed"] = log->counters().malformed;
  d["format"] = std::string(can::LogFormatName(log->format()));
  return d;
}

// The pipeline over the logs: the estimate document with its history, drives and counters.
std::string Replay(const std::string& config_path, const std::vector<std::string>& logs, bool final_only) {
  const config::Config c = config::LoadConfig(config_path);
  const dbc::Database db = dbc::ParseDbcFile(c.dbc);
  pipeline::Pipeline p(c, db);
  ReplayOptions o;
  o.logs = logs;
  o.identify_periodically = !final_only;
  ReplayOutcome out;
  {
    py::gil_scoped_release unlocked;
    out = RunReplay(p, c, o);
  }
  // Simulated data: the truth beside the (first) log, as `ndsid replay` reads it.
  out.truth_eg = TruthBesideLogs(logs.empty() ? c.source.logs : logs);
  return ReplayDocument(p, out, p.gate().counters()).dump();
}

// A fleet's per-log task: the logs read to their end by a fresh pipeline, as a CBOR document.
py::bytes Reduce(const std::string& config_path, const std::vector<std::string>& logs) {
  const config::Config c = config::LoadConfig(config_path);
  const dbc::Database db = dbc::ParseDbcFile(c.dbc);
  std::string cbor;
  {
    py::gil_scoped_release unlocked;
    cbor = ToCbor(pipeline::LogReductionToJson(ReduceLogs(c, db, logs)));
  }
  return py::bytes(cbor);
}

// A fleet's per-vehicle task: the reductions of its logs (in log order) merged and identified.
std::string IdentifyReducedJson(const std::string& config_path, const std::vector<py::bytes>& documents) {
  const config::Config c = config::LoadConfig(config_path);
  const dbc::Database db = dbc::ParseDbcFile(c.dbc);
  std::vector<std::string> raw;
  for (const py::bytes& d : documents) raw.push_back(std::string(d));
  py::gil_scoped_release unlocked;
  std::vector<pipeline::LogReduction> parts;
  for (size_t i = 0; i < raw.size(); ++i) {
    const std::string what = "reduction " + std::to_string(i);
    const nlohmann::json doc = ParseCbor(raw[i], what, CborLimits{32, size_t{1} << 28});
    parts.push_back(pipeline::LogReductionFromJson(JsonIn(doc, what)));
  }
  return IdentifyReduced(c, db, std::move(parts)).dump();
}

// compare: the model and a baseline fitted on the same window and simulated over it.
py::dict CompareModels(const std::string& config_path, const std::vector<std::string>& logs,
                 const std::optional<std::vector<std::string>>& effects, const std::vector<std::string>& baseline) {
  const config::Config cfg = config::LoadConfig(config_path);
  const std::vector<std::string> model_effects = effects ? *effects : cfg.model_effects;
  std::unique_ptr<ReplayedData> data;
  Comparison c;
  {
    py::gil_scoped_release unlocked;
    data = ReplayForModelWork(config_path, logs, model_effects);
    std::vector<FittedModel> models{FitModel(*data, "model", model_effects), FitModel(*data, "baseline", baseline)};
    c = desk::Compare(*data, std::move(models), std::nullopt);
  }
  nlohmann::json s;
  s["data"] = data->outcome.name;
  s["noise_floor_mps2"] = c.noise_floor;
  s["noise_floor_source"] = c.noise_floor_source;
  s["has_yaw_rate"] = c.has_yaw_rate;
  s["models"] = nlohmann::json::array();
  for (size_t m = 0; m < c.models.size(); ++m) {
    nlohmann::json mj = identify::ResultToJson(c.models[m].fit);
    mj["label"] = c.models[m].label;
    mj["effects"] = c.models[m].effects;
    mj["rmse_all_mps2"] = c.overall_rmse[m];
    mj["rmse_train_scored_mps2"] = c.train[m].rmse;
    mj["rmse_validation_scored_mps2"] = c.validation[m].rmse;
    mj["nrmse_fit_train_pct"] = c.train[m].nrmse_fit_pct;
    mj["nrmse_fit_validation_pct"] = c.validation[m].nrmse_fit_pct;
    mj["white_noise_mps2"] = c.white_noise[m];
    if (c.has_yaw_rate) mj["yaw_rmse_all_degps"] = c.yaw_overall_rmse[m];
    s["models"].push_back(std::move(mj));
  }
  nlohmann::json bins = nlohmann::json::array();
  auto add_bins = [&](const std::vector<Bin>& list, const char* output) {
    for (const Bin& b : list) {
      for (size_t m = 0; m < b.per_model.size(); ++m) {
        const BinStats& st = b.per_model[m];
        bins.push_back({{"output", output}, {"group", b.group}, {"bin", b.label}, {"model", c.models[m].label}, {"n", st.n},
                        {"clusters", st.clusters}, {"bias", st.bias}, {"se", st.se}, {"rmse", st.rmse},
                        {"verdict", VerdictText(st.verdict)}});
      }
    }
  };
  add_bins(c.bins, "a_y");
  if (c.has_yaw_rate) add_bins(c.yaw_bins, "yaw_rate");
  // The samples, one column each; the models' outputs as model_<label> / yaw_model_<label>.
  std::vector<double> t, steer, steer_rate, speed, ax, ay, yaw;
  std::vector<int64_t> drive;
  std::vector<int32_t> segment, chunk;
  std::vector<uint8_t> scored, validation;
  std::vector<std::vector<double>> ay_model(c.models.size()), yaw_model(c.models.size());
  for (const SampleRow& r : c.rows) {
    t.push_back(r.t_s), drive.push_back(r.drive), segment.push_back(r.segment), chunk.push_back(r.chunk);
    scored.push_back(r.scored), validation.push_back(r.validation);
    steer.push_back(r.steer_rad), steer_rate.push_back(r.steer_rate_radps), speed.push_back(r.speed_mps);
    ax.push_back(r.ax_mps2), ay.push_back(r.ay_mps2), yaw.push_back(r.yaw_rate_radps);
    for (size_t m = 0; m < c.models.size(); ++m) {
      ay_model[m].push_back(r.ay_model[m]);
      yaw_model[m].push_back(m < r.yaw_model.size() ? r.yaw_model[m] : std::nan(""));
    }
  }
  py::dict cols;
  cols["t_s"] = Column(std::move(t));
  cols["drive"] = Column(std::move(drive));
  cols["segment"] = Column(std::move(segment));
  cols["chunk"] = Column(std::move(chunk));
  cols["scored"] = Column(std::move(scored));
  cols["held_out"] = Column(std::move(validation));
  cols["steer_rad"] = Column(std::move(steer));
  cols["steer_rate_radps"] = Column(std::move(steer_rate));
  cols["speed_mps"] = Column(std::move(speed));
  cols["ax_mps2"] = Column(std::move(ax));
  cols["ay_mps2"] = Column(std::move(ay));
  cols["yaw_rate_radps"] = Column(std::move(yaw));
  for (size_t m = 0; m < c.models.size(); ++m) {
    cols[py::str("ay_" + c.models[m].label)] = Column(std::move(ay_model[m]));
    cols[py::str("yaw_rate_" + c.models[m].label)] = Column(std::move(yaw_model[m]));
  }
  py::dict d;
  d["summary"] = s.dump();
  d["bins"] = bins.dump();
  d["samples"] = cols;
  return d;
}

// Any `ndsid` command in process (the CLI's own code): returns its exit status.
int RunCommand(const std::vector<std::string>& argv) {
  CLI::App app{"ndsid"};
  app.require_subcommand(1);
  int exit_code = 0;
  for (const auto& cmd : Commands()) cmd.registrar(app, exit_code);
  std::vector<std::string> args(argv.rbegin(), argv.rend());  // CLI11 takes them reversed
  py::gil_scoped_release unlocked;
  try {
    app.parse(args);
  } catch (const CLI::ParseError& e) {
    throw ConfigError(std::string("ndsid ") + (argv.empty() ? "" : argv[0]) + ": " + e.what());
  }
  return exit_code;
}

}  // namespace
}  // namespace ndsid::desk

PYBIND11_MODULE(_ndsid, m) {
  m.doc() = "ndsid's C++ core (use the ndsid package)";
  // Translators are tried newest first: the subclass after its base.
  py::register_exception<ndsid::Error>(m, "Error", PyExc_RuntimeError);
  py::register_exception<ndsid::ConfigError>(m, "ConfigError", PyExc_ValueError);
  m.def("load_config", &ndsid::desk::LoadConfigJson, py::arg("path"));
  m.def("decode", &ndsid::desk::Decode, py::arg("log"), py::arg("dbc"), py::arg("bus") = "");
  m.def("replay", &ndsid::desk::Replay, py::arg("config"), py::arg("logs"), py::arg("final_only"));
  m.def("reduce", &ndsid::desk::Reduce, py::arg("config"), py::arg("logs"));
  m.def("identify_reduced", &ndsid::desk::IdentifyReducedJson, py::arg("config"), py::arg("documents"));
  m.def("compare", &ndsid::desk::CompareModels, py::arg("config"), py::arg("logs"), py::arg("effects"), py::arg("baseline"));
  m.def("run_command", &ndsid::desk::RunCommand, py::arg("argv"));
  m.def("set_log_level", [](const std::string& level) { spdlog::set_level(spdlog::level::from_str(level)); });
}
