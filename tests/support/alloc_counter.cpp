// Counting replacements of the global operator new / delete; see alloc_counter.h.
#include "support/alloc_counter.h"

#include <atomic>
#include <cstdlib>
#include <new>

namespace ef::test {
namespace {

// Thread-local counters of trivial type: constant-initialised, no TLS constructor or destructor,
// so they are safe to touch from inside operator new on any thread at any time.
thread_local std::uint64_t t_allocations = 0;
thread_local std::uint64_t t_deallocations = 0;
thread_local std::uint64_t t_bytes = 0;

std::atomic<std::uint64_t> g_allocations{0};
std::atomic<std::uint64_t> g_deallocations{0};
std::atomic<std::uint64_t> g_bytes{0};

void count_allocation(std::size_t size) {
  ++t_allocations;
  t_bytes += size;
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  g_bytes.fetch_add(size, std::memory_order_relaxed);
}

void count_deallocation(void* p) {
  if (p == nullptr) return;
  ++t_deallocations;
  g_deallocations.fetch_add(1, std::memory_order_relaxed);
}

void* try_allocate(std::size_t size, std::size_t align) {
  if (size == 0) size = 1;
  if (align <= alignof(std::max_align_t)) return std::malloc(size);
  if (align < sizeof(void*)) align = sizeof(void*);
  void* p = nullptr;
  return ::posix_memalign(&p, align, size) == 0 ? p : nullptr;
}

// operator new semantics: retry through the new-handler, throw std::bad_alloc when there is none.
void* allocate_or_throw(std::size_t size, std::size_t align) {
  for (;;) {
    if (void* p = try_allocate(size, align)) {
      count_allocation(size);
      return p;
    }
    std::new_handler handler = std::get_new_handler();
    if (handler == nullptr) throw std::bad_alloc();
    handler();
  }
}

void* allocate_nothrow(std::size_t size, std::size_t align) noexcept {
  try {
    return allocate_or_throw(size, align);
  } catch (...) {
    return nullptr;
  }
}

void release(void* p) noexcept {
  count_deallocation(p);
  std::free(p);  // posix_memalign memory is freed with free as well
}

}  // namespace

AllocationTotals thread_allocation_totals() { return AllocationTotals{t_allocations, t_deallocations, t_bytes}; }

AllocationTotals global_allocation_totals() {
  return AllocationTotals{g_allocations.load(std::memory_order_relaxed), g_deallocations.load(std::memory_order_relaxed),
                          g_bytes.load(std::memory_order_relaxed)};
}

bool allocation_counting_enabled() {
  const std::uint64_t before = t_allocations;
  int* volatile probe = new int(1);  // volatile: the new/delete pair must not be elided
  const bool counted = t_allocations == before + 1;
  delete probe;
  return counted;
}

}  // namespace ef::test

using ef::test::allocate_nothrow;
using ef::test::allocate_or_throw;
using ef::test::release;

namespace {
constexpr std::size_t kDefaultAlign = alignof(std::max_align_t);
}

// ---- replaceable global allocation functions (C++17 [new.delete]) ----

void* operator new(std::size_t size) { return allocate_or_throw(size, kDefaultAlign); }
void* operator new[](std::size_t size) { return allocate_or_throw(size, kDefaultAlign); }
void* operator new(std::size_t size, const std::nothrow_t&) noexcept { return allocate_nothrow(size, kDefaultAlign); }
void* operator new[](std::size_t size, const std::nothrow_t&) noexcept { return allocate_nothrow(size, kDefaultAlign); }
void* operator new(std::size_t size, std::align_val_t al) { return allocate_or_throw(size, static_cast<std::size_t>(al)); }
void* operator new[](std::size_t size, std::align_val_t al) {
  return allocate_or_throw(size, static_cast<std::size_t>(al));
}
void* operator new(std::size_t size, std::align_val_t al, const std::nothrow_t&) noexcept {
  return allocate_nothrow(size, static_cast<std::size_t>(al));
}
void* operator new[](std::size_t size, std::align_val_t al, const std::nothrow_t&) noexcept {
  return allocate_nothrow(size, static_cast<std::size_t>(al));
}

void operator delete(void* p) noexcept { release(p); }
void operator delete[](void* p) noexcept { release(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { release(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { release(p); }
void operator delete(void* p, std::size_t) noexcept { release(p); }
void operator delete[](void* p, std::size_t) noexcept { release(p); }
void operator delete(void* p, std::align_val_t) noexcept { release(p); }
void operator delete[](void* p, std::align_val_t) noexcept { release(p); }
void operator delete(void* p, std::align_val_t, const std::nothrow_t&) noexcept { release(p); }
void operator delete[](void* p, std::align_val_t, const std::nothrow_t&) noexcept { release(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { release(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { release(p); }
