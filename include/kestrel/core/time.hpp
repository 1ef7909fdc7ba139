// Time stamps: int64 nanoseconds inside Kestrel, seconds only at file edges (TUM files).
#pragma once

#include <cmath>
#include <cstdint>

namespace kestrel {

using TimeNs = std::int64_t;

constexpr double ns_to_s(TimeNs t_ns) { return static_cast<double>(t_ns) * 1e-9; }
inline TimeNs s_to_ns(double t_s) { return static_cast<TimeNs>(std::llround(t_s * 1e9)); }

}  // namespace kestrel
