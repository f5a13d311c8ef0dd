#pragma once
// Lock-free single-producer / single-consumer ring of fixed capacity.
//
// The real-time thread is the only producer and one non-RT thread the only
// consumer (or the other way round for commands). Neither ever blocks or
// allocates: the storage is allocated once in the constructor, try_push and
// try_pop are noexcept and O(1). When the ring is full, try_push drops the new
// element and counts it, so the producer (the RT cycle) never waits for a slow
// consumer; the count tells how much telemetry was lost.
//
// Memory ordering: the producer writes the slot, then publishes it with a
// release store of tail_; the consumer's acquire load of tail_ makes the slot
// contents visible. Symmetrically for head_ when the consumer frees a slot.
// Indices increase monotonically and are reduced modulo the (power-of-two)
// capacity, so all Capacity slots are usable and wrap-around of size_t is
// harmless (unsigned arithmetic).
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <type_traits>

namespace dualv {

template <typename T, std::size_t Capacity>
class SpscQueue {
  static_assert(Capacity >= 2 && (Capacity & (Capacity - 1)) == 0,
                "SpscQueue capacity must be a power of two >= 2");
  static_assert(std::is_nothrow_copy_assignable_v<T> && std::is_nothrow_default_constructible_v<T>,
                "SpscQueue elements are copied in the RT path: copy must not throw");

 public:
  // Allocates all storage up front (set-up time, may throw std::bad_alloc).
  SpscQueue() : slots_(std::make_unique<T[]>(Capacity)) {}
  SpscQueue(const SpscQueue&) = delete;
  SpscQueue& operator=(const SpscQueue&) = delete;

  static constexpr std::size_t capacity() noexcept { return Capacity; }

  // Producer only. Returns false (and counts a drop) when full.
  bool try_push(const T& value) noexcept {
    const std::size_t tail = tail_.load(std::memory_order_relaxed);
    if (tail - head_cache_ == Capacity) {
      // Refresh the cached consumer index only when the ring looks full: keeps
      // the common case free of cross-core cache traffic.
      head_cache_ = head_.load(std::memory_order_acquire);
      if (tail - head_cache_ == Capacity) {
        dropped_.fetch_add(1, std::memory_order_relaxed);
        return false;
      }
    }
    slots_[tail & kMask] = value;
    tail_.store(tail + 1, std::memory_order_release);
    return true;
  }

  // Consumer only. Returns false when empty; `out` is untouched then.
  bool try_pop(T& out) noexcept {
    const std::size_t head = head_.load(std::memory_order_relaxed);
    if (head == tail_cache_) {
      tail_cache_ = tail_.load(std::memory_order_acquire);
      if (head == tail_cache_) return false;
    }
    out = slots_[head & kMask];
    head_.store(head + 1, std::memory_order_release);
    return true;
  }

  // Elements currently queued; exact only when called from a quiescent state,
  // otherwise a snapshot (either side may be moving).
  std::size_t size_approx() const noexcept {
    return tail_.load(std::memory_order_acquire) - head_.load(std::memory_order_acquire);
  }
  bool empty_approx() const noexcept { return size_approx() == 0; }

  // Elements refused by try_push because the ring was full (any thread may read).
  std::uint64_t dropped() const noexcept { return dropped_.load(std::memory_order_relaxed); }

 private:
  static constexpr std::size_t kMask = Capacity - 1;
  // Producer and consumer state on separate cache lines (no false sharing).
  alignas(64) std::atomic<std::size_t> tail_{0};  // written by producer
  std::size_t head_cache_{0};                     // producer's view of head_
  std::atomic<std::uint64_t> dropped_{0};         // written by producer
  alignas(64) std::atomic<std::size_t> head_{0};  // written by consumer
  std::size_t tail_cache_{0};                     // consumer's view of tail_
  alignas(64) std::unique_ptr<T[]> slots_;
};

}  // namespace dualv
