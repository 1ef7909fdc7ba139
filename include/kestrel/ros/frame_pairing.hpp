// Pairs two image streams (colour + depth, left + right) by nearest time stamp: what a live
// node needs where the sensor does not stamp both images alike (Kinect v1: up to ~15 ms apart).
// Header-only and ROS-free (C++17): the node stores message pointers, the tests plain values.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>
#include <utility>

namespace kestrel::ros {

/// A pair is made as soon as an item finds an unpaired item of the other stream within
/// `max_dt_ns` (|t_a - t_b| <= max_dt_ns), the nearest one if several. Each item is used once.
/// Items too old to pair with anything newer (older than the newest time of the other stream
/// minus max_dt) and items beyond `capacity` per stream are dropped and counted. Streams are
/// expected in time order; a stamp older than the newest of its own stream clears the buffers
/// (a replayed bag starting over) and counts a restart.
template <typename A, typename B>
class NearestTimePairing {
 public:
  struct Pair {
    std::int64_t t_a = 0;
    std::int64_t t_b = 0;
    A a;
    B b;
  };

  explicit NearestTimePairing(std::int64_t max_dt_ns, std::size_t capacity = 8)
      : max_dt_ns_(max_dt_ns), capacity_(capacity == 0 ? 1 : capacity) {}

  std::optional<Pair> add_a(std::int64_t t_ns, A a) {
    if (restarted(t_ns, newest_a_)) clear_for_restart();
    newest_a_ = t_ns;
    prune(b_, t_ns);
    if (auto it = nearest(b_, t_ns); it != b_.end()) {
      Pair p{t_ns, it->first, std::move(a), std::move(it->second)};
      b_.erase(it);
      ++pairs_;
      return p;
    }
    push(a_, t_ns, std::move(a));
    return std::nullopt;
  }

  std::optional<Pair> add_b(std::int64_t t_ns, B b) {
    if (restarted(t_ns, newest_b_)) clear_for_restart();
    newest_b_ = t_ns;
    prune(a_, t_ns);
    if (auto it = nearest(a_, t_ns); it != a_.end()) {
      Pair p{it->first, t_ns, std::move(it->second), std::move(b)};
      a_.erase(it);
      ++pairs_;
      return p;
    }
    push(b_, t_ns, std::move(b));
    return std::nullopt;
  }

  [[nodiscard]] std::size_t pairs() const { return pairs_; }
  /// Items that found no partner (too old, or pushed out of a full buffer).
  [[nodiscard]] std::size_t unpaired() const { return unpaired_; }
  [[nodiscard]] std::size_t restarts() const { return restarts_; }
  [[nodiscard]] std::size_t pending() const { return a_.size() + b_.size(); }
  [[nodiscard]] std::int64_t max_dt_ns() const { return max_dt_ns_; }

 private:
  template <typename T>
  using Buffer = std::deque<std::pair<std::int64_t, T>>;

  static bool restarted(std::int64_t t_ns, const std::optional<std::int64_t>& newest) {
    return newest && t_ns < *newest;
  }
  void clear_for_restart() {
    unpaired_ += a_.size() + b_.size();
    a_.clear();
    b_.clear();
    newest_a_.reset();
    newest_b_.reset();
    ++restarts_;
  }
  template <typename T>
  void prune(Buffer<T>& buffer, std::int64_t newest_other_ns) {
    while (!buffer.empty() && buffer.front().first < newest_other_ns - max_dt_ns_) {
      buffer.pop_front();
      ++unpaired_;
    }
  }
  template <typename T>
  void push(Buffer<T>& buffer, std::int64_t t_ns, T item) {
    if (buffer.size() >= capacity_) {
      buffer.pop_front();
      ++unpaired_;
    }
    buffer.emplace_back(t_ns, std::move(item));
  }
  template <typename T>
  typename Buffer<T>::iterator nearest(Buffer<T>& buffer, std::int64_t t_ns) const {
    auto best = buffer.end();
    std::int64_t best_dt = max_dt_ns_;
    for (auto it = buffer.begin(); it != buffer.end(); ++it) {
      const std::int64_t dt = it->first > t_ns ? it->first - t_ns : t_ns - it->first;
      if (dt <= best_dt) {
        best_dt = dt;
        best = it;
      }
    }
    return best;
  }

  std::int64_t max_dt_ns_;
  std::size_t capacity_;
  Buffer<A> a_;
  Buffer<B> b_;
  std::optional<std::int64_t> newest_a_, newest_b_;
  std::size_t pairs_ = 0, unpaired_ = 0, restarts_ = 0;
};

}  // namespace kestrel::ros
