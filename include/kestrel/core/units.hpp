// Angle constants shared by every module, so that no file keeps its own copy of pi.
#pragma once

#include <numbers>

namespace kestrel {

inline constexpr double kPi = std::numbers::pi;
inline constexpr double kDegToRad = std::numbers::pi / 180.0;
inline constexpr double kRadToDeg = 180.0 / std::numbers::pi;

}  // namespace kestrel
