// Associating two lists of time stamps, as the TUM RGB-D benchmark's associate.py does.
#pragma once

#include <cstddef>
#include <vector>

#include "kestrel/core/time.hpp"
#include "kestrel/io/trajectory.hpp"

namespace kestrel::eval {

/// One association: indices into the first and the second list.
struct IndexPair {
  std::size_t first = 0;
  std::size_t second = 0;
  friend bool operator==(const IndexPair&, const IndexPair&) = default;
};

/// associate.py: every pair (a, b) with |t_a - t_b| < max_diff_ns is a candidate; candidates
/// are taken in order of increasing |t_a - t_b| (ties: earlier a, then earlier b, as Python
/// sorts the tuples) and accepted when neither stamp is used yet. The result is sorted by the
/// first index. Both lists must be strictly increasing (throws std::invalid_argument).
/// Differences are exact integer ns here, where the script uses doubles: results can differ
/// only for differences within ~1e-7 s of max_diff or of each other.
std::vector<IndexPair> associate(const std::vector<TimeNs>& first_t_ns,
                                 const std::vector<TimeNs>& second_t_ns, TimeNs max_diff_ns);

/// The time stamps of a trajectory, in order.
std::vector<TimeNs> stamps_of(const Trajectory& trajectory);

}  // namespace kestrel::eval
