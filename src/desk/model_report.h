// The engineer's model-improvement loop (`ndsid compare`, `ndsid diagnose`): logs replayed
// into a window, models fitted and simulated over it sample by sample, the residual binned by
// operating condition ("where it fails"), and the CSV / HTML / Markdown outputs.
#pragma once

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "ndsid/config/config.h"
#include "ndsid/dbc/database.h"
#include "ndsid/identify/identifier.h"
#include "ndsid/pipeline/pipeline.h"
#include "replay_runner.h"

namespace ndsid::desk {

// Logs replayed through the pipeline (one identification at the end), kept alive together:
// the pipeline holds references to config and db.
struct ReplayedData {
  config::Config config;
  dbc::Database db;
  std::unique_ptr<pipeline::Pipeline> pipeline;
  ReplayOutcome outcome;
  pipeline::WindowSnapshot window;  // training / held-out drives exactly as the pipeline fits them
  std::optional<double> truth_noise_mps2;  // noise.lat_accel_mps2 of a truth.yaml beside the first log
  bool custom_split = false;  // training / held-out drives chosen on the command line
};

// "a,b" -> {a, b}; "none" or "" -> {} (base model). Throws ConfigError for an unknown name.
// "a, b,c" -> {"a", "b", "c"}: split on commas, blanks trimmed, empty items dropped.
std::vector<std::string> SplitNames(const std::string& text);
std::vector<std::string> ParseEffectList(const std::string& text, const model::EffectLibrary& library);
std::string JoinEffects(const std::vector<std::string>& effects);  // "[a, b]"

// Throws ConfigError for a missing log or an empty window. `pipeline_effects` is the model the
// pipeline fits at the end (its fit is reused when a command wants the same model).
std::unique_ptr<ReplayedData> ReplayForModelWork(const std::string& config_path, const std::vector<std::string>& logs,
                                                 const std::vector<std::string>& pipeline_effects);

// Re-splits the window: the drives listed are held out, the others train ("--hold-out 0,3").
// Throws ConfigError for a drive not in the window or when no training drive is left.
void HoldOutDrives(ReplayedData& data, const std::vector<int64_t>& drives);
std::vector<int64_t> ParseDriveList(const std::string& text);  // "" or "auto" -> {}

struct FittedModel {
  std::string label;  // "model" / "baseline"
  std::vector<std::string> effects;
  identify::IdentificationResult fit;
};
FittedModel FitModel(const ReplayedData& data, const std::string& label, const std::vector<std::string>& effects);
// The pipeline's own valid fit of `effects` on the window's split, when it has one (no custom
// split, the pipeline's model): FitModel takes it, diagnose starts its ladder from it.
std::optional<identify::IdentificationResult> ReplayedFit(const ReplayedData& data, const std::vector<std::string>& effects);

// One 50 Hz window sample (a chunk sample of the fit), with every model's output.
struct SampleRow {
  double t_s;
  int64_t drive;
  int segment, chunk, k;  // segment index in the window, chunk index, sample index in the chunk
  bool scored;            // false inside the burn-in (not scored by the fit, not in statistics)
  bool validation;
  double steer_rad, steer_rate_radps, speed_mps, ax_mps2, ay_mps2, yaw_rate_radps;  // yaw NaN when absent
  std::vector<double> ay_model, yaw_model;  // per model
};

enum class BinVerdict { kOk, kTooFew, kFailBias, kFailRmse };
const char* VerdictText(BinVerdict v);

struct BinStats {
  size_t n = 0;
  int clusters = 0;  // chunks contributing
  double bias = 0, se = 0, rmse = 0;
  BinVerdict verdict = BinVerdict::kTooFew;
};

struct Bin {
  std::string group, label;
  std::vector<BinStats> per_model;
};

// The signed view of "where it fails": per speed band, the gain error k of the residual on the
// modelled output (e = c + k y_model: measured = model x (1 + k) where the model is right up to a
// gain), with its chunk-clustered standard error. An error odd in the output (a gain that is off)
// cancels in the bias columns of the bins; here it shows with its sign, and a gain that changes
// with speed is the signature of an effect whose gain depends on speed.
struct GainBand {
  std::string label;  // "10-15" [m/s]
  size_t n = 0;
  int clusters = 0;
  double gain = NAN, se = NAN;  // k [-]; NaN when too few samples or no spread in the output
  bool judged = false;          // at least kMinBinSamples samples in kGainMinChunks chunks
  bool flagged = false;         // judged, |k| > kGainZ se and |k| > kGainMin
};
struct GainView {
  std::vector<std::vector<GainBand>> per_model;  // [model][band]
  std::vector<double> chi2;                      // per model: the bands' gains against their mean
  std::vector<int> dof;                          // judged bands - 1
  std::vector<bool> speed_dependent;             // chi2 above its 0.999 quantile and gains > kGainMin apart
};
inline constexpr double kGainZ = 3.0;
inline constexpr double kGainMin = 0.01;  // gain errors (and their differences) below 1 % are not flagged
inline constexpr int kGainMinChunks = 10;  // a clustered SE from fewer chunks is not trusted
// Residuals of the scored rows (a_y [m/s^2], or the yaw rate when `yaw`) in 5 m/s speed bands.
GainView ComputeGainView(const std::vector<SampleRow>& rows, size_t models, bool yaw);
void PrintGainView(const GainView& view, const std::vector<FittedModel>& models, const char* output);
// gain_bands.csv rows (output,band,model,n,clusters,gain,se,judged,flagged; header when `header`), the
// summary.json object and the report's HTML table of one output's view.
std::string GainViewCsv(const GainView& view, const std::vector<FittedModel>& models, const char* output, bool header);
std::string GainViewJson(const GainView& view, const std::vector<FittedModel>& models);
std::string GainViewHtml(const GainView& view, const std::vector<FittedModel>& models, const char* output);

struct FitFigures {  // per model and set
  double rmse = -1, nrmse_fit_pct = 0, bias = 0;
  size_t n = 0;
};

struct Comparison {
  std::vector<FittedModel> models;  // [0] the model, [1] the baseline
  std::vector<SampleRow> rows;
  std::vector<double> white_noise;   // sqrt(var(diff e)/2) per model
  double noise_floor = 0;            // used for the verdicts
  std::string noise_floor_source;
  std::vector<double> overall_rmse;  // per model, all scored samples
  std::vector<FitFigures> train, validation;
  std::vector<Bin> bins;
  // The yaw rate, when every scored sample of the window has one: the residual
  // r_meas - r_model (the modelled measured yaw rate, gyro effects included) in deg/s, binned
  // by the same conditions and judged by the same rule against its own noise floor.
  bool has_yaw_rate = false;
  bool yaw_rate_fitted = false;           // identification.outputs has the yaw rate
  std::vector<double> yaw_white_noise;    // deg/s, per model
  double yaw_noise_floor = 0;             // deg/s (smallest over the models)
  std::vector<double> yaw_overall_rmse;   // deg/s, per model
  std::vector<FitFigures> yaw_train, yaw_validation;  // deg/s
  std::vector<Bin> yaw_bins;
  GainView gains, yaw_gains;  // the signed view per speed band (yaw_gains with has_yaw_rate)
};

// Failing-bin rule (docs/model-workflow.md): at least kMinBinSamples scored samples; bias
// fails when |bias| > kBiasZ * clustered SE (>= 3 chunks) and |bias| > noise_floor / 2; RMSE
// fails when above kRmseFactor * the model's overall RMSE.
inline constexpr size_t kMinBinSamples = 250;  // 5 s at 50 Hz
inline constexpr double kBiasZ = 3.0;
inline constexpr double kRmseFactor = 1.5;
BinStats ComputeBin(const std::vector<double>& e, const std::vector<int>& cluster, double noise_floor,
                    double overall_rmse);


Comparison Compare(const ReplayedData& data, std::vector<FittedModel> models, std::optional<double> noise_floor);
void PrintComparison(const Comparison& c);

// Runs scripts/model_report_plots.py <mode> <dir> in the project venv (output in <dir>/plots.log);
// false with the reason when not.
bool RunPlotScript(const std::string& mode, const std::string& dir, std::string* why_not);

std::string HtmlEscape(const std::string& s);

}  // namespace ndsid::desk
