// BoundedQueue semantics (drop-oldest, blocking, close, timeouts) and the statistics helpers.
// No timing assertions: threads are only ever checked for what they return after join().
#include <gtest/gtest.h>

#include <chrono>
#include <thread>
#include <vector>

#include "kestrel/pipeline/bounded_queue.hpp"
#include "kestrel/pipeline/stage_stats.hpp"

namespace kestrel::pipeline {
namespace {

TEST(BoundedQueue, DropsTheOldestWhenFullAndCountsIt) {
  BoundedQueue<int> q(3);
  for (int i = 1; i <= 5; ++i) EXPECT_TRUE(q.push(i));
  EXPECT_EQ(q.size(), 3u);
  EXPECT_EQ(q.dropped(), 2u);
  EXPECT_EQ(q.pushed(), 5u);
  EXPECT_EQ(q.pop(), 3);  // 1 and 2 were stale
  EXPECT_EQ(q.pop(), 4);
  EXPECT_EQ(q.pop(), 5);
  EXPECT_EQ(q.size(), 0u);
}

TEST(BoundedQueue, ZeroCapacityIsRejected) {
  EXPECT_THROW(BoundedQueue<int>(0), std::invalid_argument);
}

TEST(BoundedQueue, PopForTimesOutOnAnEmptyOpenQueue) {
  BoundedQueue<int> q(2);
  EXPECT_FALSE(q.pop_for(std::chrono::milliseconds(1)).has_value());
  EXPECT_FALSE(q.closed());
  q.push(7);
  EXPECT_EQ(q.pop_for(std::chrono::milliseconds(1)), 7);
}

TEST(BoundedQueue, CloseKeepsQueuedItemsAndRefusesNewOnes) {
  BoundedQueue<int> q(4);
  q.push(1);
  q.push(2);
  q.close();
  q.close();  // idempotent
  EXPECT_FALSE(q.push(3));
  EXPECT_EQ(q.pushed(), 2u);
  EXPECT_EQ(q.dropped(), 0u);
  EXPECT_EQ(q.pop(), 1);
  EXPECT_EQ(q.pop(), 2);
  EXPECT_FALSE(q.pop().has_value());
  EXPECT_FALSE(q.pop_for(std::chrono::seconds(10)).has_value());  // closed: returns at once
}

TEST(BoundedQueue, CloseWakesAWaitingConsumer) {
  BoundedQueue<int> q(1);
  std::optional<int> got = 42;
  std::thread consumer([&] { got = q.pop(); });
  q.close();
  consumer.join();  // would hang forever if close() did not wake pop()
  EXPECT_FALSE(got.has_value());
}

TEST(BoundedQueue, CloseWakesAProducerBlockedOnAFullQueue) {
  BoundedQueue<int> q(1, OverflowPolicy::kBlock);
  ASSERT_TRUE(q.push(1));
  bool accepted = true;
  std::thread producer([&] { accepted = q.push(2); });
  q.close();
  producer.join();
  EXPECT_FALSE(accepted);
  EXPECT_EQ(q.pop(), 1);
  EXPECT_FALSE(q.pop().has_value());
}

TEST(BoundedQueue, BlockingPolicyLosesNothingAndKeepsOrder) {
  BoundedQueue<int> q(2, OverflowPolicy::kBlock);
  constexpr int kItems = 2000;
  std::thread producer([&] {
    for (int i = 0; i < kItems; ++i) q.push(i);
    q.close();
  });
  std::vector<int> got;
  while (auto v = q.pop()) got.push_back(*v);
  producer.join();
  ASSERT_EQ(got.size(), static_cast<std::size_t>(kItems));
  for (int i = 0; i < kItems; ++i) EXPECT_EQ(got[static_cast<std::size_t>(i)], i);
  EXPECT_EQ(q.dropped(), 0u);
}

TEST(BoundedQueue, DropOldestWithConcurrentProducersAccountsForEveryItem) {
  BoundedQueue<int> q(4);
  constexpr int kPerProducer = 5000;
  std::vector<std::thread> producers;
  for (int p = 0; p < 2; ++p) {
    producers.emplace_back([&] {
      for (int i = 0; i < kPerProducer; ++i) q.push(i);
    });
  }
  std::size_t popped = 0;
  std::thread consumer([&] {
    while (q.pop()) ++popped;
  });
  for (auto& t : producers) t.join();
  q.close();
  consumer.join();
  EXPECT_EQ(q.pushed(), 2u * kPerProducer);
  EXPECT_EQ(popped + q.dropped(), 2u * kPerProducer);  // every item was either used or dropped
}

TEST(StageStats, NearestRankPercentiles) {
  std::vector<double> v;
  for (int i = 100; i >= 1; --i) v.push_back(i);
  EXPECT_DOUBLE_EQ(percentile(v, 0.5), 50.0);
  EXPECT_DOUBLE_EQ(percentile(v, 0.95), 95.0);
  EXPECT_DOUBLE_EQ(percentile(v, 1.0), 100.0);
  EXPECT_DOUBLE_EQ(percentile(v, 0.0), 1.0);
  EXPECT_DOUBLE_EQ(percentile({}, 0.5), 0.0);
  const Percentiles p = summarize({3.0, 1.0, 2.0});
  EXPECT_DOUBLE_EQ(p.p50, 2.0);
  EXPECT_DOUBLE_EQ(p.max, 3.0);
}

TEST(StageStats, RateFromTheFirstToTheLastItem) {
  StageStats s;
  const auto t0 = Clock::now();
  s.add_processing(t0, t0 + std::chrono::milliseconds(5));
  EXPECT_DOUBLE_EQ(s.rate_hz(), 0.0);  // one item: no rate
  s.add_processing(t0, t0 + std::chrono::milliseconds(105));
  s.add_processing(t0, t0 + std::chrono::milliseconds(205));
  EXPECT_NEAR(s.rate_hz(), 10.0, 1e-9);  // 2 intervals over 0.2 s
  s.add_output(t0, t0 + std::chrono::milliseconds(30));
  EXPECT_EQ(s.out, 1u);
  EXPECT_NEAR(s.latency_ms.at(0), 30.0, 1e-9);
}

}  // namespace
}  // namespace kestrel::pipeline
