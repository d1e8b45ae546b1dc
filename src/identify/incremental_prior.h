// The incremental update's prior inside one fit (private to the identify stage,
// docs/incremental.md): the training segments the prior holds enter the fit as their chunks'
// quadratics (QuadraticPrior), the others are simulated (FitProblem). This owns the distance rule
// (which segments the estimate has left), the relinearisation of stale segments in place and the
// re-weighting of the prior to the whole window's output weights; the prior it started from is
// never changed (a copy holds the re-weighted or relinearised quadratics).
//
// The quadratics are straight valleys where the true cost's valley is curved: along directions
// the data hardly determine, the estimate can slide far while the Mahalanobis distance stays
// small, and EG (a nonlinear function of the parameters) moves with it. Two guards: a prior
// chunk is simulated again when any scaled parameter moved more than kRelinearizeStep from its
// linearisation point (25 % of a base parameter's initial value, 12.5 % of an effect's box);
// and the EG check of every incremental solution (eg_check.h).
#pragma once

#include <Eigen/Dense>

#include <cstddef>
#include <memory>
#include <vector>

#include "fit_problem.h"
#include "ndsid/identify/linearized_window.h"
#include "quadratic_prior.h"

namespace ndsid::identify {

constexpr double kRelinearizeStep = 0.25;
// An ordinary update whose solution lies within this many of the prior's standard deviations of
// the estimate where the same quadratics last passed the check (LinearizedWindow::checked_at,
// e.g. an update whose new data all went to held-out drives) is not checked again: the
// quadratics' error there moves EG by about as much as it did at that check.
constexpr double kRecheckSigma = 0.01;
// An exact update (IncrementalUpdate::exact) relinearises every prior chunk the estimate lies
// further than this many of its standard deviations from, once, at its first solution.
constexpr double kExactSigma = 0.05;

// The prior's segment and the window's are the same data (drive, start and length).
bool SameSegment(const LinearizedSegment& l, const stats::Segment& s);

class IncrementalPrior {
 public:
  // One training segment the prior holds, with its chunks' quadratics (in window()).
  struct Segment {
    const stats::Segment* seg;
    const LinearizedSegment* lin;
  };
  // The prior's J'J and noise level, taken once for the guards that read them at one state of
  // the prior (the distance rule, the re-check distance and the EG check of one round).
  struct Moments {
    Eigen::MatrixXd h;
    double level;
  };
  // How far a point lies from a segment's linearisation points: the largest squared Mahalanobis
  // distance (prior J'J h over its noise level) and the largest single step over its chunks.
  struct Distance {
    double worst = 0, step = 0;
    Eigen::VectorXd worst_d;  // the move from the worst chunk's linearisation point
    bool beyond(double rule) const { return !(worst <= rule * rule) || !(step <= kRelinearizeStep); }
  };

  // theta0: the start, the anchor along the prior's weak directions (QuadraticPrior).
  IncrementalPrior(const FitSettings& settings, const LinearizedWindow& window, const std::vector<double>& theta0);

  // Takes the training segments the prior holds (the same data); returns the others, to simulate.
  SegmentList Split(const SegmentList& training);

  const LinearizedWindow& window() const { return *window_; }
  const std::vector<Segment>& segments() const { return segments_; }
  size_t NumChunks() const;
  // The chunks of the held segments whose data have a yaw rate (counted by the data, not by the
  // quadratics: those of a prior built for a_y alone hold no yaw-rate residuals).
  size_t ChunksWithYawRate() const;

  // The held chunks' autocorrelation sums (both outputs pooled) added into acf; returns their residuals.
  double PoolSums(std::vector<double>& acf) const;
  // The noise level sigma^2 tau of the held chunks' (weighted) residuals.
  double Level() const;
  // Their information sum J'J (theta space).
  Eigen::MatrixXd Jtj() const;
  Moments TakeMoments() const { return {Jtj(), Level()}; }
  static Distance DistanceOf(const LinearizedSegment& ls, const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::MatrixXd& h,
                             double level);
  // The held segments whose linearisation points lie more than `rule` of the prior's own
  // standard deviation from `at` (or a step beyond kRelinearizeStep): they are simulated again.
  std::vector<size_t> StaleSegments(const std::vector<double>& at, double rule, const Moments& pm) const;
  // Whether the solution theta lies within kRecheckSigma of where the same quadratics (every
  // segment of the prior in the fit) already passed the EG check.
  bool CheckedNear(const std::vector<double>& theta, const Moments& pm) const;

  // With both outputs, the weights of the whole window: the new data's noise level per output at
  // theta pooled with the prior's (its chunks' autocorrelation sums, unweighted), as a full fit
  // sets them from all the data. A prior that keeps each chunk's yaw-rate part is re-weighted to
  // them exactly, and the problem's weights set to them; an older one holds its own.
  void ReweightToWindow(FitProblem& fit, bool two_outputs);
  // The stale segments relinearised in place: each chunk simulated once with its Jacobian at
  // theta (weighted by `weights`), its quadratic replaced by the one there. Adds the chunks to
  // `count`; false where a chunk could not be relinearised.
  bool Relinearize(const std::vector<size_t>& stale, const std::vector<double>& theta, const std::vector<double>& scale,
                   const std::shared_ptr<const OutputWeights>& weights, bool two_outputs, size_t& count);
  // The fit's quadratic cost from the held chunks as they are now.
  void SetQuadratic();
  QuadraticPrior& quadratic() { return quadratic_; }

 private:
  // Points every held segment into `copy`, a copy of window_, and makes it the window.
  void Repoint(const LinearizedWindow& copy);

  const FitSettings& settings_;
  int np_;                                              // parameters of the model
  const LinearizedWindow* window_;                      // the prior as it is now: the update's or a copy below
  std::shared_ptr<const LinearizedWindow> reweighted_;  // the copy re-weighted to the whole window's weights
  std::shared_ptr<LinearizedWindow> relinearized_;      // the copy with relinearised segments
  std::vector<Segment> segments_;                       // the training segments the prior holds, in training order
  std::vector<double> theta0_;                          // the start: the anchor along the prior's weak directions
  QuadraticPrior quadratic_;                            // the held chunks' quadratics as one cost on theta
};

}  // namespace ndsid::identify
