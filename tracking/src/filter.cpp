#include "kumite/tracking/filter.hpp"

#include <algorithm>
#include <cmath>

namespace kumite::tracking {

double LowPassFilter::filter(double value, double alpha) {
  const double result = initialised_ ? alpha * value + (1.0 - alpha) * smoothed_ : value;
  initialised_ = true;
  raw_ = value;
  smoothed_ = result;
  return result;
}

OneEuroFilter::OneEuroFilter(double frequency_hz, double min_cutoff_hz, double beta, double d_cutoff_hz)
    : frequency_(frequency_hz), min_cutoff_(min_cutoff_hz), beta_(beta), d_cutoff_(d_cutoff_hz) {}

double OneEuroFilter::alpha(double frequency, double cutoff) {
  const double te = 1.0 / frequency;
  const double tau = 1.0 / (2.0 * M_PI * cutoff);
  return 1.0 / (1.0 + tau / te);
}

double OneEuroFilter::filter(double value, double timestamp) {
  if (has_time_ && timestamp > last_time_) frequency_ = 1.0 / (timestamp - last_time_);
  last_time_ = timestamp;
  has_time_ = true;
  // As the reference since 08/2023: the speed is measured from the last FILTERED value.
  const double dvalue = x_.has_last_raw() ? (value - x_.last()) * frequency_ : 0.0;
  const double edvalue = d_.filter(dvalue, alpha(frequency_, d_cutoff_));
  const double cutoff = min_cutoff_ + beta_ * std::abs(edvalue);
  return x_.filter(value, alpha(frequency_, cutoff));
}

void OneEuroFilter::reset() {
  x_ = {};
  d_ = {};
  has_time_ = false;
  last_time_ = -1;
}

// ---------------------------------------------------------------------------------------

PoseFilter::PoseFilter(const FilterConfig& config, double frequency_hz)
    : config_(config),
      frequency_(frequency_hz),
      axis_{OneEuroFilter(frequency_hz, config.min_cutoff_hz, config.beta, config.d_cutoff_hz),
            OneEuroFilter(frequency_hz, config.min_cutoff_hz, config.beta, config.d_cutoff_hz),
            OneEuroFilter(frequency_hz, config.min_cutoff_hz, config.beta, config.d_cutoff_hz)} {}

void PoseFilter::reset() {
  for (auto& a : axis_) a.reset();
  for (auto& r : rot_d_) r = {};
  for (auto& v : vel_) v = {};
  last_t_ = -1;
  state_ = {};
}

const FilteredState& PoseFilter::update(Timestamp t, const Eigen::Vector3d& position,
                                        const Eigen::Quaterniond& orientation) {
  const Eigen::Quaterniond q = orientation.normalized();
  if (!config_.enabled) {
    state_.velocity = state_.valid && t > state_.timestamp
                          ? Eigen::Vector3d((position - state_.position) / (t - state_.timestamp))
                          : Eigen::Vector3d::Zero();
    state_ = {t, position, state_.velocity, q, Eigen::Vector3d::Zero(), true};
    return state_;
  }
  const bool had = state_.valid;
  const Eigen::Vector3d before = state_.position;
  if (had && last_t_ >= 0 && t > last_t_) frequency_ = 1.0 / (t - last_t_);
  const auto alpha = [&](double cutoff) {
    const double tau = 1.0 / (2.0 * M_PI * cutoff);
    return 1.0 / (1.0 + tau * frequency_);
  };
  for (int k = 0; k < 3; ++k) {
    state_.position[k] = axis_[k].filter(position[k], t);
    const double v = had ? (state_.position[k] - before[k]) * frequency_ : 0.0;
    state_.velocity[k] = vel_[k].filter(v, alpha(kVelocityCutoffHz));
  }
  if (!had) {
    state_.orientation = q;
    state_.angular_velocity.setZero();
  } else {
    Eigen::Quaterniond dq = q * last_raw_.conjugate();  // room-frame rotation since last sample
    if (dq.w() < 0) dq.coeffs() = -dq.coeffs();
    const double s = dq.vec().norm();
    const double angle = 2.0 * std::atan2(s, dq.w());
    const Eigen::Vector3d omega = s > 1e-12 ? Eigen::Vector3d(dq.vec() / s * angle * frequency_)
                                            : Eigen::Vector3d::Zero();
    const double ad = alpha(config_.rot_d_cutoff_hz);
    for (int k = 0; k < 3; ++k) state_.angular_velocity[k] = rot_d_[k].filter(omega[k], ad);
    const double cutoff = config_.rot_min_cutoff_hz + config_.rot_beta * state_.angular_velocity.norm();
    Eigen::Quaterniond target = q;
    if (state_.orientation.dot(target) < 0) target.coeffs() = -target.coeffs();
    state_.orientation = state_.orientation.slerp(alpha(cutoff), target).normalized();
  }
  last_raw_ = q;
  last_t_ = t;
  state_.timestamp = t;
  state_.valid = true;
  return state_;
}

void predict(const FilteredState& state, Timestamp t, double max_prediction_s,
             Eigen::Vector3d& position, Eigen::Quaterniond& orientation) {
  const double dt = std::clamp(t - state.timestamp, 0.0, std::max(0.0, max_prediction_s));
  position = state.position + state.velocity * dt;
  const double angle = state.angular_velocity.norm() * dt;
  if (angle > 1e-12) {
    orientation = (Eigen::Quaterniond(Eigen::AngleAxisd(angle, state.angular_velocity.normalized())) *
                   state.orientation).normalized();
  } else {
    orientation = state.orientation;
  }
}

}  // namespace kumite::tracking
