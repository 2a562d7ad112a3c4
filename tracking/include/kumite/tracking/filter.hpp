#pragma once
// The One Euro filter (Casiez, Roussel, Vogel, "1 EUR Filter", CHI 2012), exactly as the
// authors' reference C++ implementation (casiez/OneEuroFilter): the sampling frequency follows
// the timestamps, the first sample passes through, the speed is (x - last filtered x) * frequency
// (the reference's 08/2023 fix; its groundTruth.csv is reproduced to 1e-5 in the tests).
// PoseFilter applies it to a position (per axis) and an orientation (on the rotation angle,
// smoothing by slerp), and keeps the filtered velocities for prediction to a display time.
#include <Eigen/Core>
#include <Eigen/Geometry>

#include "kumite/common/time.hpp"
#include "kumite/tracking/config.hpp"

namespace kumite::tracking {

class LowPassFilter {
 public:
  double filter(double value, double alpha);
  bool has_last_raw() const { return initialised_; }
  double last_raw() const { return raw_; }
  double last() const { return smoothed_; }

 private:
  double raw_ = 0, smoothed_ = 0;
  bool initialised_ = false;
};

class OneEuroFilter {
 public:
  /// frequency_hz: initial sampling rate (replaced by the timestamps' once two arrive).
  OneEuroFilter(double frequency_hz, double min_cutoff_hz, double beta, double d_cutoff_hz);
  /// Filters one sample taken at `timestamp` (s). As in the reference, the frequency becomes
  /// 1 / (timestamp - previous timestamp) only when the timestamp increases.
  double filter(double value, double timestamp);
  /// The filter's smoothed speed term (value units per second): as in the reference, the
  /// change from the last FILTERED value, so it is not the signal's velocity.
  double derivative() const { return d_.last(); }
  void reset();

 private:
  static double alpha(double frequency, double cutoff);
  double frequency_, min_cutoff_, beta_, d_cutoff_;
  double last_time_ = -1;
  bool has_time_ = false;
  LowPassFilter x_, d_;
};

/// Filtered state of one body, trivially copyable (published across threads).
struct FilteredState {
  Timestamp timestamp = 0;                   ///< s: time of the last measurement
  Eigen::Vector3d position{0, 0, 0};         ///< m
  Eigen::Vector3d velocity{0, 0, 0};         ///< m/s: the filtered position's, low-passed at 5 Hz
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d angular_velocity{0, 0, 0}; ///< rad/s, room frame
  bool valid = false;
};

class PoseFilter {
 public:
  explicit PoseFilter(const FilterConfig& config, double frequency_hz = 60);
  /// Feeds one measurement; returns the filtered state.
  const FilteredState& update(Timestamp t, const Eigen::Vector3d& position,
                              const Eigen::Quaterniond& orientation);
  const FilteredState& state() const { return state_; }
  void reset();

 private:
  FilterConfig config_;
  double frequency_;
  OneEuroFilter axis_[3];
  LowPassFilter rot_d_[3];  // angular velocity, room frame (rad/s)
  LowPassFilter vel_[3];    // velocity of the filtered position (m/s), for prediction
  static constexpr double kVelocityCutoffHz = 5.0;
  Eigen::Quaterniond last_raw_ = Eigen::Quaterniond::Identity();
  Timestamp last_t_ = -1;
  FilteredState state_;
};

/// The filtered pose extrapolated to time `t` (s) with the filtered velocities, by at most
/// `max_prediction_s` (and never backwards past the measurement).
void predict(const FilteredState& state, Timestamp t, double max_prediction_s,
             Eigen::Vector3d& position, Eigen::Quaterniond& orientation);

}  // namespace kumite::tracking
