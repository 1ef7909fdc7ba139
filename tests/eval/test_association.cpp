// Association of time stamps: the edge cases of associate.py, and agreement with a literal
// transcription of the script on random lists.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <set>
#include <stdexcept>
#include <tuple>

#include "kestrel/eval/association.hpp"

namespace kestrel::eval {
namespace {

using Pairs = std::vector<IndexPair>;

/// associate.py as written: all pairs, sorted as tuples, greedy, sorted by first.
Pairs associate_literally(const std::vector<TimeNs>& a, const std::vector<TimeNs>& b,
                          TimeNs max_diff) {
  std::vector<std::tuple<TimeNs, TimeNs, TimeNs>> potential;
  for (const TimeNs ta : a) {
    for (const TimeNs tb : b) {
      if (std::abs(ta - tb) < max_diff) potential.emplace_back(std::abs(ta - tb), ta, tb);
    }
  }
  std::sort(potential.begin(), potential.end());
  std::set<TimeNs> first(a.begin(), a.end()), second(b.begin(), b.end());
  std::vector<std::pair<TimeNs, TimeNs>> matches;
  for (const auto& [diff, ta, tb] : potential) {
    if (first.count(ta) != 0 && second.count(tb) != 0) {
      first.erase(ta);
      second.erase(tb);
      matches.emplace_back(ta, tb);
    }
  }
  std::sort(matches.begin(), matches.end());
  Pairs out;
  for (const auto& [ta, tb] : matches) {
    out.push_back({static_cast<std::size_t>(std::find(a.begin(), a.end(), ta) - a.begin()),
                   static_cast<std::size_t>(std::find(b.begin(), b.end(), tb) - b.begin())});
  }
  return out;
}

TEST(Association, EmptyListsGiveNoPairs) {
  EXPECT_TRUE(associate({}, {}, 20).empty());
  EXPECT_TRUE(associate({1, 2}, {}, 20).empty());
  EXPECT_TRUE(associate({}, {1, 2}, 20).empty());
}

TEST(Association, IdenticalStampsPairOneToOne) {
  EXPECT_EQ(associate({10, 20, 30}, {10, 20, 30}, 1), (Pairs{{0, 0}, {1, 1}, {2, 2}}));
}

TEST(Association, MaxDifferenceIsExclusive) {
  EXPECT_TRUE(associate({100}, {120}, 20).empty());
  EXPECT_TRUE(associate({120}, {100}, 20).empty());
  EXPECT_EQ(associate({100}, {119}, 20), (Pairs{{0, 0}}));
}

TEST(Association, ClosestPairWinsAndEachStampIsUsedOnce) {
  // 6 is 4 from 10 and 6 from 0: it goes to 10, and 0 stays alone.
  EXPECT_EQ(associate({0, 10}, {6}, 20), (Pairs{{1, 0}}));
  // Greedy, as the script, not a maximum matching: (10, 8) goes first, and then neither
  // (0, 8) nor (10, 19) is free, although those two pairs would both fit.
  EXPECT_EQ(associate({0, 10}, {8, 19}, 11), (Pairs{{1, 0}}));
}

TEST(Association, TiesGoToTheEarlierStamp) {
  EXPECT_EQ(associate({0, 10}, {5}, 20), (Pairs{{0, 0}}));
  EXPECT_EQ(associate({5}, {0, 10}, 20), (Pairs{{0, 0}}));
}

TEST(Association, ResultIsSortedByFirstIndex) {
  // Accepted in the order (100, 99), (300, 301), (200, 202); returned in first-stamp order.
  const Pairs pairs = associate({0, 100, 200, 300}, {99, 202, 301}, 5);
  EXPECT_EQ(pairs, (Pairs{{1, 0}, {2, 1}, {3, 2}}));
}

TEST(Association, RefusesUnsortedOrDuplicateStamps) {
  EXPECT_THROW(associate({2, 1}, {1}, 5), std::invalid_argument);
  EXPECT_THROW(associate({1}, {3, 3}, 5), std::invalid_argument);
}

TEST(Association, AgreesWithTheScriptOnRandomLists) {
  std::mt19937 rng(42);
  for (int trial = 0; trial < 200; ++trial) {
    // Coarse stamps make ties and exact threshold hits common.
    std::uniform_int_distribution<TimeNs> stamp(0, 200);
    std::set<TimeNs> a_set, b_set;
    const int na = std::uniform_int_distribution<int>(0, 40)(rng);
    const int nb = std::uniform_int_distribution<int>(0, 40)(rng);
    for (int i = 0; i < na; ++i) a_set.insert(stamp(rng));
    for (int i = 0; i < nb; ++i) b_set.insert(stamp(rng));
    const std::vector<TimeNs> a(a_set.begin(), a_set.end()), b(b_set.begin(), b_set.end());
    const TimeNs max_diff = std::uniform_int_distribution<TimeNs>(1, 12)(rng);
    ASSERT_EQ(associate(a, b, max_diff), associate_literally(a, b, max_diff)) << trial;
  }
}

TEST(Association, StampsOfATrajectory) {
  const Trajectory trajectory = {{5, SE3()}, {7, SE3()}};
  EXPECT_EQ(stamps_of(trajectory), (std::vector<TimeNs>{5, 7}));
}

}  // namespace
}  // namespace kestrel::eval
