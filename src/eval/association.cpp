// Time-stamp association (TUM RGB-D benchmark, associate.py) for trajectories.
#include "kestrel/eval/association.hpp"

#include <algorithm>
#include <stdexcept>

#include "kestrel/io/tum_rgbd.hpp"

namespace kestrel::eval {
namespace {

void require_increasing(const std::vector<TimeNs>& t_ns, const char* which) {
  if (std::adjacent_find(t_ns.begin(), t_ns.end(), std::greater_equal<>()) != t_ns.end()) {
    throw std::invalid_argument(std::string("associate: ") + which +
                                " time stamps are not strictly increasing");
  }
}

}  // namespace

std::vector<IndexPair> associate(const std::vector<TimeNs>& first_t_ns,
                                 const std::vector<TimeNs>& second_t_ns, TimeNs max_diff_ns) {
  require_increasing(first_t_ns, "first");
  require_increasing(second_t_ns, "second");
  // io::associate_by_time applies the script's rule (closest pair first, ties by earlier
  // first then earlier second stamp) over the candidates inside the window only.
  std::vector<IndexPair> matches;
  for (const auto& [first, second] : io::associate_by_time(first_t_ns, second_t_ns, max_diff_ns)) {
    matches.push_back({first, second});
  }
  return matches;
}

std::vector<TimeNs> stamps_of(const Trajectory& trajectory) {
  std::vector<TimeNs> t_ns;
  t_ns.reserve(trajectory.size());
  for (const StampedPose& pose : trajectory) t_ns.push_back(pose.t_ns);
  return t_ns;
}

}  // namespace kestrel::eval
