// A bounded, closable multi-producer multi-consumer queue between pipeline stages. A real-time
// stage must never fall behind its input: when the queue is full the OLDEST item is dropped
// (and counted), so the consumer always works on the freshest data. The blocking policy exists
// for offline runs where every frame must be processed (back-pressure instead of drops).
// close() is the shutdown signal: it wakes every waiter, so no thread can hang on a queue.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <utility>

namespace kestrel::pipeline {

enum class OverflowPolicy {
  kDropOldest,  ///< full: discard the oldest item, never wait (real time)
  kBlock,       ///< full: the producer waits for space or close() (offline, nothing lost)
};

template <class T>
class BoundedQueue {
 public:
  explicit BoundedQueue(std::size_t capacity, OverflowPolicy policy = OverflowPolicy::kDropOldest)
      : capacity_(capacity), policy_(policy) {
    if (capacity == 0) throw std::invalid_argument("BoundedQueue: capacity must be at least 1");
  }
  BoundedQueue(const BoundedQueue&) = delete;
  BoundedQueue& operator=(const BoundedQueue&) = delete;

  /// Adds `item`; false (item discarded, not counted as a drop) if the queue is closed.
  bool push(T item) {
    std::unique_lock lock(mutex_);
    if (policy_ == OverflowPolicy::kBlock) {
      not_full_.wait(lock, [&] { return closed_ || items_.size() < capacity_; });
    }
    if (closed_) return false;
    if (items_.size() >= capacity_) {
      items_.pop_front();
      ++dropped_;
    }
    items_.push_back(std::move(item));
    ++pushed_;
    lock.unlock();
    not_empty_.notify_one();
    return true;
  }

  /// The oldest item; waits for one. nullopt once the queue is closed and empty.
  std::optional<T> pop() {
    std::unique_lock lock(mutex_);
    not_empty_.wait(lock, [&] { return closed_ || !items_.empty(); });
    return take(lock);
  }

  /// As pop(), waiting at most `timeout`: nullopt on timeout too (closed() tells which).
  template <class Rep, class Period>
  std::optional<T> pop_for(std::chrono::duration<Rep, Period> timeout) {
    std::unique_lock lock(mutex_);
    not_empty_.wait_for(lock, timeout, [&] { return closed_ || !items_.empty(); });
    return take(lock);
  }

  /// No more pushes; the items still queued can be popped. Wakes every waiter. Idempotent.
  void close() {
    {
      std::lock_guard lock(mutex_);
      closed_ = true;
    }
    not_empty_.notify_all();
    not_full_.notify_all();
  }

  [[nodiscard]] bool closed() const {
    std::lock_guard lock(mutex_);
    return closed_;
  }
  [[nodiscard]] std::size_t size() const {
    std::lock_guard lock(mutex_);
    return items_.size();
  }
  /// Items discarded because the queue was full (drop-oldest policy).
  [[nodiscard]] std::size_t dropped() const {
    std::lock_guard lock(mutex_);
    return dropped_;
  }
  /// Items accepted by push() (dropped ones included).
  [[nodiscard]] std::size_t pushed() const {
    std::lock_guard lock(mutex_);
    return pushed_;
  }
  [[nodiscard]] std::size_t capacity() const { return capacity_; }
  [[nodiscard]] OverflowPolicy policy() const { return policy_; }

 private:
  std::optional<T> take(std::unique_lock<std::mutex>& lock) {
    if (items_.empty()) return std::nullopt;
    std::optional<T> out;
    out.emplace(std::move(items_.front()));
    items_.pop_front();
    lock.unlock();
    not_full_.notify_one();
    return out;
  }

  const std::size_t capacity_;
  const OverflowPolicy policy_;
  mutable std::mutex mutex_;
  std::condition_variable not_empty_;
  std::condition_variable not_full_;
  std::deque<T> items_;
  bool closed_ = false;
  std::size_t dropped_ = 0;
  std::size_t pushed_ = 0;
};

}  // namespace kestrel::pipeline
