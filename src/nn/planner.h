// Activation memory planning: every int8 tensor of a model gets an offset in one arena, computed once
// at load. Tensors whose lifetimes do not overlap share bytes (liveness-based reuse), and an
// elementwise layer (add, clamp) writes over an input that dies at that layer (in place).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/result.h"
#include "nn/model_format.h"

namespace ef::nn {

struct PlanOptions {
  bool reuse = true;             // share bytes between tensors whose lifetimes are disjoint
  bool in_place = true;          // let add / clamp write over a dying input of the same shape
  std::size_t alignment = 64;    // bytes; every offset is a multiple (a cache line, AVX-512 vectors)
};

struct MemoryPlan {
  static constexpr std::size_t kNotInArena = ~std::size_t{0};
  std::vector<std::size_t> offset;  // per tensor id: byte offset in the arena, or kNotInArena
                                    // (the float output, written to the caller's buffer; unused tensors)
  std::vector<std::size_t> bytes;   // per tensor id: its size in the arena (0 when not in it)
  std::vector<int> first_use;       // per tensor: producing layer (-1: graph input)
  std::vector<int> last_use;        // per tensor: last layer reading it (first_use when never read)
  std::size_t total_bytes = 0;      // arena size needed (peak)
  std::size_t sum_bytes = 0;        // sum of all placed tensor sizes (aligned): the no-reuse size
  int in_place_count = 0;           // layers that write over their input
};

// Plans `model` (validated, so it cannot fail on a loaded model; returns kInternal on a broken
// invariant).
Result<MemoryPlan> plan_memory(const Model& model, const PlanOptions& options = {});

}  // namespace ef::nn
