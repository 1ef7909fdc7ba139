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
  // The positive scores and their indices, packed in image order. Branch-free: every value is
  // written and the end advances only past a positive one (NaN and s <= 0 fail the test), so a
  // ragged mix of textured and flat pixels costs no mispredicted branch.
  auto& index = scratch.index;
  auto& score = scratch.score;
  if (index.size() < n) {
    index.resize(n);
    score.resize(n);
  }
  std::size_t m = 0;
  for (std::size_t j = 0; j < n; ++j) {
    const float s = scores[j];
    index[m] = static_cast<int>(j);
    score[m] = s;
    m += s > 0.0F ? 1 : 0;
  }
  if (cap == 0 || m <= cap) {
    out.assign(index.begin(), index.begin() + static_cast<std::ptrdiff_t>(m));
    return;
  }
  // Positives below 2^-126 (denormals) land in bucket 0.
  auto& hist = scratch.histogram;
  hist.fill(0);
  for (std::size_t i = 0; i < m; ++i) ++hist[bucket_of(score[i])];
  // The bucket holding the cap-th largest score, and how many scores lie above it.
  std::size_t above = 0;
  std::uint32_t b = static_cast<std::uint32_t>(hist.size() - 1);
  while (above + hist[b] < cap) above += hist[b--];
  // Every score at or above that bucket's lower bound, kept in place (still in image order);
  // then the cut-off among the bucket's own scores.
  const float lower = std::bit_cast<float>(b << kShift);
  std::size_t kept = 0;
  for (std::size_t i = 0; i < m; ++i) {
    const float s = score[i];
    index[kept] = index[i];
    score[kept] = s;
    kept += s >= lower ? 1 : 0;
  }
  auto& in_bucket = scratch.bucket;
  in_bucket.clear();
  for (std::size_t i = 0; i < kept; ++i) {
    if (bucket_of(score[i]) == b) in_bucket.push_back(score[i]);
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
  out.resize(cap);
  std::size_t acc = ties / 2, taken = 0;
  for (std::size_t i = 0; i < kept; ++i) {
    const float s = score[i];
    bool keep = s > cut;
    if (s == cut) {
      acc += ties_needed;
      keep = acc >= ties;
      acc -= keep ? ties : 0;
    }
    if (keep) out[taken++] = index[i];
  }
  out.resize(taken);
}

}  // namespace kestrel::odometry
