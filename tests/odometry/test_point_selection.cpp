// Pixel selection: the radix cut-off against a full sort, ties spread over the image.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <vector>

#include "kestrel/odometry/point_selection.hpp"

namespace kestrel::odometry {
namespace {

// The multiset of the cap largest positive scores, by sorting.
std::vector<float> top_scores(std::vector<float> s, std::size_t cap) {
  s.erase(std::remove_if(s.begin(), s.end(), [](float v) { return !(v > 0.0F); }), s.end());
  std::sort(s.begin(), s.end(), std::greater<>());
  if (cap > 0 && s.size() > cap) s.resize(cap);
  return s;
}

TEST(SelectStrongest, SameScoresAsAFullSortInImageOrder) {
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> size(1, 20000);
  std::uniform_int_distribution<int> kind(0, 3);
  SelectionScratch scratch;
  std::vector<int> out;
  for (int trial = 0; trial < 200; ++trial) {
    const auto n = static_cast<std::size_t>(size(rng));
    std::vector<float> s(n);
    const int k = kind(rng);
    std::exponential_distribution<float> expo(30.0F);
    std::uniform_int_distribution<int> levels(-2, 6);      // many ties and non-positive values
    std::lognormal_distribution<float> wide(0.0F, 15.0F);  // many exponents
    for (auto& v : s) {
      if (k == 0) v = expo(rng);
      if (k == 1) v = static_cast<float>(levels(rng)) / 255.0F;
      if (k == 2) v = wide(rng);
      if (k == 3) v = (levels(rng) == 0) ? std::numeric_limits<float>::quiet_NaN() : expo(rng);
    }
    std::uniform_int_distribution<std::size_t> cap_pick(0, n + 10);
    const std::size_t cap = cap_pick(rng);
    select_strongest(s, cap, out, scratch);
    ASSERT_TRUE(std::is_sorted(out.begin(), out.end())) << trial;
    ASSERT_TRUE(std::adjacent_find(out.begin(), out.end()) == out.end()) << "duplicates, " << trial;
    std::vector<float> got;
    for (const int i : out) got.push_back(s[static_cast<std::size_t>(i)]);
    std::sort(got.begin(), got.end(), std::greater<>());
    ASSERT_EQ(got, top_scores(s, cap)) << "trial " << trial << " n " << n << " cap " << cap;
  }
}

TEST(SelectStrongest, TiesAtTheCutOffAreSpreadOverTheImage) {
  // 10 rows of 1000 equal scores, 2000 wanted: each row gives 200, not the first two rows all.
  std::vector<float> s(10000, 0.25F);
  SelectionScratch scratch;
  std::vector<int> out;
  select_strongest(s, 2000, out, scratch);
  ASSERT_EQ(out.size(), 2000U);
  for (int row = 0; row < 10; ++row) {
    const auto in_row =
        std::count_if(out.begin(), out.end(), [row](int i) { return i / 1000 == row; });
    EXPECT_EQ(in_row, 200) << "row " << row;
  }
}

TEST(SelectStrongest, NothingPositiveSelectsNothing) {
  std::vector<float> s = {0.0F, -1.0F, std::numeric_limits<float>::quiet_NaN(), -0.0F};
  SelectionScratch scratch;
  std::vector<int> out = {7};
  select_strongest(s, 2, out, scratch);
  EXPECT_TRUE(out.empty());
  select_strongest(std::vector<float>{}, 5, out, scratch);
  EXPECT_TRUE(out.empty());
}

}  // namespace
}  // namespace kestrel::odometry
