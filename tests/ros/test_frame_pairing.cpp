// NearestTimePairing: the live node's pairing of colour/depth (left/right) images.
#include <gtest/gtest.h>

#include <random>

#include "kestrel/ros/dataset_bridge.hpp"
#include "kestrel/ros/frame_pairing.hpp"

namespace kestrel::ros {
namespace {

constexpr std::int64_t kMs = 1'000'000;

TEST(FramePairing, PairsEqualStampsInEitherOrder) {
  NearestTimePairing<int, int> p(20 * kMs);
  EXPECT_FALSE(p.add_a(100 * kMs, 1));
  const auto pair = p.add_b(100 * kMs, 2);
  ASSERT_TRUE(pair);
  EXPECT_EQ(pair->a, 1);
  EXPECT_EQ(pair->b, 2);
  EXPECT_FALSE(p.add_b(133 * kMs, 4));
  const auto second = p.add_a(133 * kMs, 3);
  ASSERT_TRUE(second);
  EXPECT_EQ(second->t_a, 133 * kMs);
  EXPECT_EQ(second->t_b, 133 * kMs);
  EXPECT_EQ(p.pairs(), 2u);
  EXPECT_EQ(p.pending(), 0u);
}

TEST(FramePairing, TakesTheNearestWithinTolerance) {
  NearestTimePairing<int, int> p(20 * kMs);
  EXPECT_FALSE(p.add_b(90 * kMs, 10));
  EXPECT_FALSE(p.add_b(98 * kMs, 11));
  EXPECT_FALSE(p.add_b(115 * kMs, 12));
  const auto pair = p.add_a(100 * kMs, 1);
  ASSERT_TRUE(pair);
  EXPECT_EQ(pair->b, 11);  // 2 ms away; 10 ms and 15 ms lose
}

TEST(FramePairing, NothingBeyondTheTolerance) {
  NearestTimePairing<int, int> p(20 * kMs);
  EXPECT_FALSE(p.add_b(100 * kMs, 10));
  EXPECT_FALSE(p.add_a(121 * kMs, 1));  // 21 ms: no pair; the old depth is pruned
  EXPECT_EQ(p.unpaired(), 1u);
  EXPECT_TRUE(p.add_b(125 * kMs, 11));  // pairs with the waiting colour image
}

TEST(FramePairing, BoundedBuffersCountWhatTheyDrop) {
  NearestTimePairing<int, int> p(20 * kMs, 3);
  for (int i = 0; i < 10; ++i) EXPECT_FALSE(p.add_a(i * kMs, i));
  EXPECT_EQ(p.pending(), 3u);
  EXPECT_EQ(p.unpaired(), 7u);
}

TEST(FramePairing, TimeGoingBackClearsTheBuffers) {
  NearestTimePairing<int, int> p(20 * kMs);
  EXPECT_FALSE(p.add_a(1000 * kMs, 1));
  EXPECT_FALSE(p.add_a(10 * kMs, 2));  // a bag replayed from its start
  EXPECT_EQ(p.restarts(), 1u);
  const auto pair = p.add_b(10 * kMs, 3);
  ASSERT_TRUE(pair);
  EXPECT_EQ(pair->a, 2);
}

// On Kinect-like streams (30 Hz each, depth offset within +-15 ms, arrival order shuffled
// between the two topics), the live pairing finds the same pairs as the benchmark's greedy
// association used for folders and bags.
TEST(FramePairing, AgreesWithTheBenchmarkAssociationOnJitteredStreams) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<std::int64_t> offset(-15 * kMs, 15 * kMs);
  std::bernoulli_distribution depth_first(0.5);
  for (int run = 0; run < 50; ++run) {
    std::vector<std::int64_t> rgb, depth;
    for (int i = 0; i < 60; ++i) {
      rgb.push_back(1'000'000 * kMs + i * 33 * kMs);
      depth.push_back(rgb.back() + offset(rng));
    }
    const auto expected = associate_stamps(rgb, depth, kTumMaxAssociationDiffNs);
    NearestTimePairing<std::size_t, std::size_t> p(kTumMaxAssociationDiffNs);
    std::vector<std::pair<std::size_t, std::size_t>> got;
    for (std::size_t i = 0; i < rgb.size(); ++i) {
      std::optional<NearestTimePairing<std::size_t, std::size_t>::Pair> a, b;
      if (depth_first(rng)) {
        b = p.add_b(depth[i], i);
        a = p.add_a(rgb[i], i);
      } else {
        a = p.add_a(rgb[i], i);
        b = p.add_b(depth[i], i);
      }
      for (const auto& pair : {a, b}) {
        if (pair) got.emplace_back(pair->a, pair->b);
      }
    }
    std::sort(got.begin(), got.end());
    EXPECT_EQ(got, expected) << "run " << run;
  }
}

}  // namespace
}  // namespace kestrel::ros
