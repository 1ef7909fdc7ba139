// Pixel selection for the direct tracker (thesis 3.5's "all or selected pixels"): the pixels
// of highest score (squared gradient magnitude), at most a given number per pyramid level.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace kestrel::odometry {

/// Reusable buffers of select_strongest(): no allocation once they have grown.
struct SelectionScratch {
  std::array<std::uint32_t, 4096> histogram{};
  std::vector<int> index;    ///< the positive scores' indices, packed
  std::vector<float> score;  ///< ... and their scores
  std::vector<float> bucket;
};

/// Appends to `out` (cleared first) the indices of the `cap` largest positive `scores`, or of
/// all positive scores when there are fewer or `cap` is 0, in increasing index order (the
/// image order, so that the warp reads the current image nearly sequentially). Scores <= 0 or
/// NaN are never selected. Where the cut-off falls among equal scores (common on 8-bit images,
/// whose gradients take few values), the tied pixels taken are spread evenly over their index
/// range rather than taken from the top of the image. O(n): a histogram over the float bits
/// finds the cut-off (radix selection) instead of sorting.
void select_strongest(std::span<const float> scores, std::size_t cap, std::vector<int>& out,
                      SelectionScratch& scratch);

}  // namespace kestrel::odometry
