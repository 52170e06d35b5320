// Counting heap allocations in tests.
//
// alloc_counter.cpp replaces the global operator new / operator delete (every C++17 form: plain,
// array, nothrow, aligned, sized) of the test binary that compiles it with versions that forward to
// malloc/free and count. This works under ASan and TSan too: they intercept malloc/free, and a
// program may always replace operator new.
//
// Usage:
//   ef::test::AllocationCounter count;          // starts counting at construction
//   ... code under test ...
//   EXPECT_EQ(count.thread_allocations(), 0u);  // allocations made by this thread since then
//   EXPECT_EQ(count.global_allocations(), 0u);  // by every thread since then
//
// Only allocations through operator new are seen (std containers, std::string, make_unique,
// new-expressions); direct malloc calls (C libraries, codecs) are not.
#pragma once

#include <cstddef>
#include <cstdint>

namespace ef::test {

// Monotonic totals since the program started. Thread totals are those of the calling thread.
struct AllocationTotals {
  std::uint64_t allocations = 0;    // calls of any operator new that returned memory
  std::uint64_t deallocations = 0;  // calls of any operator delete with a non-null pointer
  std::uint64_t bytes = 0;          // bytes requested by those operator new calls
};
AllocationTotals thread_allocation_totals();
AllocationTotals global_allocation_totals();

// True when the counting operator new is linked into this binary (it is, when alloc_counter.cpp
// is compiled in); lets a test check its own premise.
bool allocation_counting_enabled();

// A scope that snapshots the counters at construction; the accessors return the differences.
// thread_* values are for the thread that constructed the counter; call them from that thread.
class AllocationCounter {
 public:
  AllocationCounter() { restart(); }

  void restart() {
    thread_start_ = thread_allocation_totals();
    global_start_ = global_allocation_totals();
  }

  std::uint64_t thread_allocations() const { return thread_allocation_totals().allocations - thread_start_.allocations; }
  std::uint64_t thread_deallocations() const {
    return thread_allocation_totals().deallocations - thread_start_.deallocations;
  }
  std::uint64_t thread_bytes() const { return thread_allocation_totals().bytes - thread_start_.bytes; }

  std::uint64_t global_allocations() const { return global_allocation_totals().allocations - global_start_.allocations; }
  std::uint64_t global_deallocations() const {
    return global_allocation_totals().deallocations - global_start_.deallocations;
  }
  std::uint64_t global_bytes() const { return global_allocation_totals().bytes - global_start_.bytes; }

 private:
  AllocationTotals thread_start_;
  AllocationTotals global_start_;
};

}  // namespace ef::test
