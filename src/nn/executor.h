// Runs a validated model: layers in file order on one arena planned at creation. After create(),
// run() never touches the heap (tests/nn/test_nn_zero_alloc.cpp).
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
#include "core/thread_pool.h"
#include "kernels/variants.h"
#include "nn/conv_kernels.h"
#include "nn/layers_ref.h"
#include "nn/model_format.h"
#include "nn/planner.h"

namespace ef::nn {

struct ExecutorOptions {
  PlanOptions plan;
  // Threads for splitting each convolution by output rows; borrowed, must outlive the executor.
  // nullptr (default): every layer runs on the calling thread.
  ThreadPool* pool = nullptr;
  // Highest ISA level the kernels may use (default: whatever the CPU and EF_ISA allow). Tests set
  // it to run the whole network on each variant; Isa::scalar gives the reference layers.
  kernels::Isa max_isa = kernels::Isa::neondot;
};

class Executor {
 public:
  // Plans the arena, allocates it once, picks each layer's kernel variant, repacks convolution
  // weights into their variant's layout (once, here) and binds every layer to its buffers.
  static Result<std::unique_ptr<Executor>> create(const Model& model, const ExecutorOptions& options);
  static Result<std::unique_ptr<Executor>> create(const Model& model, const PlanOptions& options = {}) {
    ExecutorOptions o;
    o.plan = options;
    return create(model, o);
  }

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
  // The kernel variant layer `layer` runs ("conv_i8__avx2", "softmax_i8__neon", "concat_i8_ref"
  // under an Isa::scalar cap...; "" for an index past the last layer).
  const char* kernel_name(std::size_t layer) const;
  // Bytes of repacked weights held by this executor.
  std::size_t packed_bytes() const { return packed_ ? packed_->used() : 0; }
  // The capacity of the packed-weight arena create() allocates for `model` (every convolution's
  // blob in its variant's layout, 64-byte aligned): at most 64 bytes above packed_bytes().
  static std::size_t packed_bytes_for(const Model& model, const ExecutorOptions& options = {});
  std::size_t arena_bytes() const { return plan_.total_bytes; }
  std::size_t input_floats() const { return input_elems_; }
  std::size_t output_floats() const { return output_elems_; }

 private:
  struct Step;
  Executor(const Model& model, MemoryPlan plan, const ExecutorOptions& options);
  Status bind();
  Status pack_weights();
  void run_conv(Step& s);
  void quantize_input(const float* input);
  void run_layers(float* probs);

  const Model& model_;
  MemoryPlan plan_;
  ExecutorOptions options_;
  std::unique_ptr<Arena> arena_;
  std::unique_ptr<Arena> packed_;  // repacked convolution weights, 64-byte aligned per layer
  int8_t* base_ = nullptr;
  std::vector<Step> steps_;
  std::vector<double> input_mul_;  // per input channel: scale[c] / input tensor scale
  std::size_t input_elems_ = 0, output_elems_ = 0;

 public:
  ~Executor();
};

}  // namespace ef::nn
