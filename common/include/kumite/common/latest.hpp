#pragma once
// LatestValue<T>: a single-writer, many-reader "latest value" slot that never blocks either
// side (a seqlock). The tracker thread publishes poses here; the render loop reads the newest
// one each frame without waiting. T must be trivially copyable (wire structs are).
//
// The payload is stored as relaxed atomic words, so there is no data race in the C++ sense
// (the usual seqlock formulation, H.-J. Boehm, "Can seqlocks get along with programming
// language memory models?", 2012).
#include <array>
#include <atomic>
#include <cstdint>
#include <cstring>
#include <optional>
#include <type_traits>

namespace kumite {

template <typename T>
class LatestValue {
  static_assert(std::is_trivially_copyable_v<T>, "LatestValue<T> needs a trivially copyable T");
  static constexpr std::size_t kWords = (sizeof(T) + sizeof(std::uint64_t) - 1) / sizeof(std::uint64_t);

 public:
  /// Writer side (one thread only). Never waits.
  void publish(const T& value) noexcept {
    std::array<std::uint64_t, kWords> buf{};
    std::memcpy(buf.data(), &value, sizeof(T));
    const std::uint64_t s = seq_.load(std::memory_order_relaxed);
    seq_.store(s + 1, std::memory_order_relaxed);
    std::atomic_thread_fence(std::memory_order_release);
    for (std::size_t i = 0; i < kWords; ++i) words_[i].store(buf[i], std::memory_order_relaxed);
    seq_.store(s + 2, std::memory_order_release);
  }

  /// Reader side (any thread). Returns std::nullopt until something was published. Retries
  /// only while a publish is in flight (a few hundred nanoseconds at most).
  std::optional<T> read() const noexcept {
    std::array<std::uint64_t, kWords> buf{};
    for (;;) {
      const std::uint64_t s1 = seq_.load(std::memory_order_acquire);
      if (s1 == 0) return std::nullopt;
      if (s1 & 1U) continue;
      for (std::size_t i = 0; i < kWords; ++i) buf[i] = words_[i].load(std::memory_order_relaxed);
      std::atomic_thread_fence(std::memory_order_acquire);
      if (seq_.load(std::memory_order_relaxed) == s1) break;
    }
    T out;
    std::memcpy(static_cast<void*>(&out), buf.data(), sizeof(T));
    return out;
  }

  /// How many values were published so far.
  std::uint64_t version() const noexcept { return seq_.load(std::memory_order_acquire) / 2; }

 private:
  std::atomic<std::uint64_t> seq_{0};
  std::array<std::atomic<std::uint64_t>, kWords> words_{};
};

}  // namespace kumite
