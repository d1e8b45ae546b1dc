// The ranking's score test of a per-drive candidate parameter (model::EffectParam::per_drive;
// load_change's load ratio, gyro_offset_per_drive's offset): one sensitivity column per drive,
// g_d = d(e)/d(value) on that drive's chunks (the column of the candidate's parameter, restricted
// to the drive). Projected against the fitted parameters, which absorb what all drives share (for
// a parameter with a common mode, exactly: a common load is cv and ch), the joint score gives the
// drop in RSS of fitting a value per drive; significance from chi^2 = dRSS / (sigma^2 tau) on the
// projected columns' rank.
#pragma once

#include <Eigen/Dense>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "ndsid/discover/diagnosis.h"

namespace ndsid::discover {

struct PerDriveScore {
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

  int col = -1;                          // the candidate's column in the scoring model
  bool pinned = false;                   // its common mode is in the base parameters (a load)
  std::string effect, param, unit;

  // One chunk of drive `drive`: A its Jacobian (all columns of the scoring model), e its residuals.
  void Add(int64_t drive, const Eigen::Map<const RowMajor>& A, const Eigen::Map<const Eigen::VectorXd>& e);

  // M = A'A, Ae = A'e over all columns of the scoring model. Projected against the fitted
  // parameters and, for a parameter without a common mode, against its own column too: the score
  // is the spread between drives beyond one common value (which the parameter's global form would
  // fit).
  CandidateScore Score(const Eigen::MatrixXd& M, const Eigen::VectorXd& Ae, std::vector<int> fitted, double rss,
                       size_t n, const std::vector<std::vector<double>>& residuals, double z_threshold) const;

  std::map<int64_t, int> index;         // drive id -> column
  std::vector<Eigen::VectorXd> a_g;     // per drive: A' g_d (all columns of the scoring model)
  std::vector<double> g_g, g_e;        // per drive: g_d' g_d, g_d' e
};

}  // namespace ndsid::discover
