// Radix selection of the strongest pixels (see point_selection.hpp).
#include "kestrel/odometry/point_selection.hpp"

#include <algorithm>
#include <bit>
#include <functional>

namespace kestrel::odometry {
namespace {

// Positive IEEE-754 floats order like their bits read as unsigned integers: the top 12 bits
// below the sign (8 of exponent, 4 of mantissa) name a bucket, and buckets order like values.
constexpr int kShift = 31 - 12;
std::uint32_t bucket_of(float s) { return std::bit_cast<std::uint32_t>(s) >> kShift; }

}  // namespace

void select_strongest(std::span<const float> scores, std::size_t cap, std::vector<int>& out,
                      SelectionScratch& scratch) {
  out.clear();
  const std::size_t n = scores.size();
  auto& hist = scratch.histogram;
  hist.fill(0);
  std::size_t positive = 0;
  for (const float s : scores) {
    // NaN and s <= 0 fail the test; positives below 2^-126 (denormals) land in bucket 0.
    const bool take = s > 0.0F;
    hist[take ? bucket_of(s) : 0] += take ? 1U : 0U;
    positive += take ? 1 : 0;
  }
  if (cap == 0 || positive <= cap) {
    out.reserve(positive);
    for (std::size_t j = 0; j < n; ++j) {
      if (scores[j] > 0.0F) out.push_back(static_cast<int>(j));
    }
    return;
  }
  // The bucket holding the cap-th largest score, and how many scores lie above it.
  std::size_t above = 0;
  std::uint32_t b = static_cast<std::uint32_t>(hist.size() - 1);
  while (above + hist[b] < cap) above += hist[b--];
  // One pass: every pixel at or above that bucket's lower bound, in image order; then the cut-off
  // among the bucket's own scores, and a filter of that short list (~cap + the bucket) in place.
  const float lower = std::bit_cast<float>(b << kShift);
  for (std::size_t j = 0; j < n; ++j) {
    if (scores[j] >= lower) out.push_back(static_cast<int>(j));
  }
  auto& in_bucket = scratch.bucket;
  in_bucket.clear();
  for (const int j : out) {
    const float s = scores[static_cast<std::size_t>(j)];
    if (bucket_of(s) == b) in_bucket.push_back(s);
  }
  // The cut-off: the (cap - above)-th largest of the bucket.
  const std::size_t rank = cap - above - 1;
  std::nth_element(in_bucket.begin(), in_bucket.begin() + static_cast<std::ptrdiff_t>(rank),
                   in_bucket.end(), std::greater<>());
  const float cut = in_bucket[rank];
  std::size_t greater = above, ties = 0;
  for (const float s : in_bucket) {
    greater += s > cut ? 1 : 0;
    ties += s == cut ? 1 : 0;
  }
  const std::size_t ties_needed = cap - greater;
  // Keep every score above the cut-off and ties_needed of the ties, spread evenly (Bresenham).
  std::size_t acc = ties / 2, kept = 0;
  for (const int j : out) {
    const float s = scores[static_cast<std::size_t>(j)];
    bool keep = s > cut;
    if (s == cut) {
      acc += ties_needed;
      keep = acc >= ties;
      acc -= keep ? ties : 0;
    }
    out[kept] = j;
    kept += keep ? 1 : 0;
  }
  out.resize(kept);
}

}  // namespace kestrel::odometry
