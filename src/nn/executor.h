// Runs a validated model: layers in file order on one arena planned at creation. After create(),
// run() never touches the heap (tests/core/test_nn_zero_alloc.cpp).
//
// Ownership: the executor borrows the Model (it must outlive the executor) and owns its arena.
// Threads: one executor per thread; several executors may share one Model.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "core/arena.h"
#include "core/result.h"
#include "nn/layers_ref.h"
#include "nn/model_format.h"
#include "nn/planner.h"

namespace ef::nn {

class Executor {
 public:
  // Plans the arena, allocates it once and binds every layer to its kernel and buffers.
  static Result<std::unique_ptr<Executor>> create(const Model& model, const PlanOptions& options = {});

  Executor(const Executor&) = delete;
  Executor& operator=(const Executor&) = delete;

  // input: the model's input image, H x W x C floats interleaved (HWC; C = 4: R, G, B in [0, 255]
  // and depth in metres, 0 = invalid), row-major without padding; input_floats must be H*W*C.
  // Each value is normalised with the model's mean/scale and quantised (docs/model_format.md).
  // probs: H' x W' x K floats (K = number of classes, innermost), the output tensor's shape;
  // probs_floats must be exactly that. Errors (sizes) are kInvalidArgument.
  Status run(const float* input, std::size_t input_floats, float* probs, std::size_t probs_floats);

  // The int8 input after quantisation, for tests and for feeding already quantised data:
  // run_quantized() skips the float stage and reads `input_q` (H*W*C int8 in the input's quantisation).
  Status run_quantized(const int8_t* input_q, std::size_t input_bytes, float* probs, std::size_t probs_floats);

  // A tensor's bytes in the arena after run() (nullptr for the float output or unused tensors); for
  // tests and debugging. Valid until the next run (buffers are reused).
  const int8_t* tensor_data(uint32_t tensor_id) const;

  const MemoryPlan& plan() const { return plan_; }
  std::size_t arena_bytes() const { return plan_.total_bytes; }
  std::size_t input_floats() const { return input_elems_; }
  std::size_t output_floats() const { return output_elems_; }

 private:
  struct Step;
  Executor(const Model& model, MemoryPlan plan);
  Status bind();
  void quantize_input(const float* input);
  void run_layers(float* probs);

  const Model& model_;
  MemoryPlan plan_;
  std::unique_ptr<Arena> arena_;
  int8_t* base_ = nullptr;
  std::vector<Step> steps_;
  std::vector<double> input_mul_;  // per input channel: scale[c] / input tensor scale
  std::size_t input_elems_ = 0, output_elems_ = 0;

 public:
  ~Executor();
};

}  // namespace ef::nn
