// NisNoiseScale: the odometry covariance's online scale from the updates' NIS
// (fusion/adaptive_noise.hpp).
#include "kestrel/fusion/adaptive_noise.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "kestrel/core/error.hpp"

namespace kestrel::fusion {

void AdaptiveNoiseOptions::validate() const {
  if (!(std::isfinite(window_updates) && window_updates >= 1.0)) {
    throw InputError("adaptive_vo_noise_window: must be >= 1 update, got " +
                     std::to_string(window_updates));
  }
  if (!(std::isfinite(min_scale) && min_scale > 0.0)) {
    throw InputError("adaptive_vo_noise_min_scale: must be positive, got " +
                     std::to_string(min_scale));
  }
  if (!(std::isfinite(max_scale) && (max_scale == 0.0 || max_scale >= min_scale))) {
    throw InputError(
        "adaptive_vo_noise_max_scale: must be 0 (the gate over the degrees of freedom) or >= "
        "adaptive_vo_noise_min_scale, got " +
        std::to_string(max_scale));
  }
}

NisNoiseScale::NisNoiseScale(const AdaptiveNoiseOptions& options, double nis_cap, int dof)
    : alpha_(0.0),
      cap_(nis_cap),
      dof_(static_cast<double>(dof)),
      lower_(0.0),
      upper_(0.0),
      scale_(1.0) {
  options.validate();
  if (!(std::isfinite(nis_cap) && nis_cap > 0.0)) {
    throw std::invalid_argument("NisNoiseScale: the NIS cap must be finite and positive");
  }
  if (dof < 1) throw std::invalid_argument("NisNoiseScale: dof must be >= 1");
  alpha_ = 1.0 / options.window_updates;
  lower_ = options.min_scale;
  upper_ = options.max_scale > 0.0 ? options.max_scale : std::max(lower_, cap_ / dof_);
  scale_ = std::clamp(1.0, lower_, upper_);
}

void NisNoiseScale::add(double nis, double scale_used) {
  if (!(std::isfinite(nis) && nis >= 0.0)) {
    throw std::invalid_argument("NisNoiseScale::add: the NIS must be finite and >= 0, got " +
                                std::to_string(nis));
  }
  if (!(std::isfinite(scale_used) && scale_used > 0.0)) {
    throw std::invalid_argument(
        "NisNoiseScale::add: the scale used must be finite and positive, got " +
        std::to_string(scale_used));
  }
  const double evidence = scale_used * std::min(nis, cap_) / dof_;
  scale_ = std::clamp((1.0 - alpha_) * scale_ + alpha_ * evidence, lower_, upper_);
  ++samples_;
}

std::string NisNoiseScale::describe() const {
  std::ostringstream s;
  s << "scale " << scale_ << " in [" << lower_ << ", " << upper_ << "] after " << samples_
    << " updates";
  return s.str();
}

}  // namespace kestrel::fusion
