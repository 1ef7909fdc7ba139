// Names of the odometry measurement references (fusion/odometry_measurement.hpp).
#include "kestrel/fusion/odometry_measurement.hpp"

#include <stdexcept>

namespace kestrel::fusion {

std::string_view odometry_reference_name(OdometryReference reference) {
  return reference == OdometryReference::kKeyframe ? "keyframe" : "previous_frame";
}

OdometryReference parse_odometry_reference(std::string_view name) {
  if (name == "keyframe") return OdometryReference::kKeyframe;
  if (name == "previous_frame") return OdometryReference::kPreviousFrame;
  throw std::invalid_argument("'" + std::string(name) +
                              "' is not an odometry reference (keyframe, previous_frame)");
}

}  // namespace kestrel::fusion
