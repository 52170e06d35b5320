// A fixed arena for per-frame scratch memory: one block allocated at start-up, bump-pointer
// allocation during a frame, reset() at the end of the frame. Never touches the heap after
// construction. Exhaustion is counted and reported (nullptr), never silently served from the heap.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <new>

namespace ef {

class Arena {
 public:
  // capacity_bytes: size of the block, allocated here, once.
  explicit Arena(std::size_t capacity_bytes)
      : block_(new (std::align_val_t(kMaxAlign)) unsigned char[capacity_bytes]), capacity_(capacity_bytes) {}
  ~Arena() = default;
  Arena(const Arena&) = delete;
  Arena& operator=(const Arena&) = delete;

  // Uninitialised storage for n objects of T, aligned to `align` (a power of two, at most 64 bytes).
  // Returns nullptr and counts a failure when the arena is exhausted.
  template <class T>
  T* allocate(std::size_t n, std::size_t align = alignof(T)) {
    if (n > capacity_ / sizeof(T)) { ++failures_; return nullptr; }  // also guards n * sizeof(T) overflow
    return static_cast<T*>(allocate_bytes(n * sizeof(T), align < alignof(T) ? alignof(T) : align));
  }

  void* allocate_bytes(std::size_t bytes, std::size_t align) {
    if (align == 0 || (align & (align - 1)) != 0 || align > kMaxAlign) { ++failures_; return nullptr; }
    const std::size_t start = (used_ + align - 1) & ~(align - 1);
    if (start > capacity_ || bytes > capacity_ - start) { ++failures_; return nullptr; }
    used_ = start + bytes;
    if (used_ > high_water_) high_water_ = used_;
    return block_.get() + start;
  }

  // Frees everything allocated since construction or the last reset (no destructors run: keep
  // trivially destructible types here).
  void reset() { used_ = 0; }

  std::size_t capacity() const { return capacity_; }
  std::size_t used() const { return used_; }
  std::size_t high_water() const { return high_water_; }   // largest `used` ever reached, bytes
  std::uint64_t failures() const { return failures_; }      // allocations refused for lack of room

  static constexpr std::size_t kMaxAlign = 64;  // a cache line; covers AVX-512 vectors

 private:
  struct AlignedDelete {
    void operator()(unsigned char* p) const { ::operator delete[](p, std::align_val_t(kMaxAlign)); }
  };
  std::unique_ptr<unsigned char[], AlignedDelete> block_;
  std::size_t capacity_;
  std::size_t used_ = 0;
  std::size_t high_water_ = 0;
  std::uint64_t failures_ = 0;
};

}  // namespace ef
