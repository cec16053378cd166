#pragma once
// The GNSS that real streets give, for the drive simulator: multipath episodes (slowly varying
// biases of metres, some reported as RTK-fixed), float stretches, isolated outliers, fixes
// without covariance and a biased stretch at the very end. Each is switchable; all are off by
// default (a clean RTK receiver). No ROS in here.

#include <Eigen/Core>
#include <cstdint>
#include <random>
#include <vector>

namespace flexcloud::sim {

struct GnssErrors {
  /// Multipath episodes per km of route; each a bias that rises and falls smoothly (sin^2) over
  /// its duration while its direction turns slowly.
  double multipath_per_km = 0.0;
  double multipath_min_s = 5.0;     ///< shortest episode, s
  double multipath_max_s = 60.0;    ///< longest episode, s
  double multipath_min_m = 1.0;     ///< smallest peak horizontal bias, m
  double multipath_max_m = 8.0;     ///< largest peak horizontal bias, m
  double multipath_vertical = 0.5;  ///< vertical bias as a share of the horizontal one
  double multipath_jitter = 0.3;    ///< m, white noise added inside an episode (0: none)
  /// Share of episodes the receiver reports as RTK-fixed (its normal std-dev) while biased; the
  /// others report multipath_std.
  double false_rtk_share = 0.5;
  double multipath_std = 1.5;  ///< m reported inside honest episodes
  /// Float stretches per km: noise float_noise, reported float_std.
  double float_per_km = 0.0;
  double float_min_s = 10.0;
  double float_max_s = 40.0;
  double float_noise = 0.4;
  double float_std = 0.6;
  /// Share of fixes that are isolated outliers, offset by outlier_min_m..outlier_max_m; the
  /// given share of them claims the normal RTK std-dev.
  double outlier_share = 0.0;
  double outlier_min_m = 3.0;
  double outlier_max_m = 30.0;
  double outlier_false_rtk_share = 0.5;
  /// Share of fixes sent without covariance (COVARIANCE_TYPE_UNKNOWN).
  double no_covariance_share = 0.0;
  /// A biased stretch of false RTK fixes at the very end of the drive (s; 0: none), with no
  /// clean fix after it: the bias ramps in over 2 s to end_bias_m.
  double end_false_rtk_s = 0.0;
  double end_bias_m = 3.0;
  /// An error that wanders slowly, as a GNSS/INS solution's does: per axis a first-order
  /// Gauss-Markov process of 1-sigma correlated_m (the vertical twice that) and time constant
  /// correlated_tau_s, on top of the white noise; 0: none.
  double correlated_m = 0.0;
  double correlated_tau_s = 30.0;
};

/// The urban receiver of issue 9's table: multipath episodes of 1-8 m (half reported as
/// RTK-fixed), float stretches, 2 % outliers.
GnssErrors urbanGnss();

/// The error of one fix and what the receiver reports about it.
struct GnssErrorSample {
  Eigen::Vector3d error = Eigen::Vector3d::Zero();  ///< added to the true antenna position, ENU
  /// Reported 1-sigma std-devs (ENU); NaN: no covariance given. Default (normal) when
  /// `normal` is true.
  Eigen::Vector3d reported_std = Eigen::Vector3d::Zero();
  bool normal = true;  ///< no error of this model applies: the receiver's normal noise
};

/// Draws the episodes of a drive once, then the error of each fix.
class GnssErrorModel {
 public:
  /// `duration` (s) and `length` (m) of the whole drive; `rtk_std` the receiver's normal
  /// reported std-devs (ENU).
  GnssErrorModel(const GnssErrors& e, double duration, double length,
                 const Eigen::Vector3d& rtk_std, std::uint64_t seed);

  /// The error of the fix at `t` seconds after the start.
  GnssErrorSample at(double t);

 private:
  struct Episode {
    double start, duration, peak, heading, turn_rate, vertical;
    bool false_rtk;
  };
  struct Stretch {
    double start, duration;
  };

  Eigen::Vector3d episodeBias(const Episode& e, double t) const;

  /// The slowly wandering error at t (GnssErrors::correlated_m), from a generator of its own.
  Eigen::Vector3d correlatedAt(double t);

  GnssErrors e_;
  double duration_;
  std::mt19937_64 correlated_rng_;
  bool correlated_started_ = false;
  double correlated_t_ = 0.0;
  Eigen::Vector3d correlated_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d rtk_std_;
  std::mt19937_64 rng_;
  std::vector<Episode> episodes_;
  std::vector<Stretch> floats_;
};

}  // namespace flexcloud::sim
