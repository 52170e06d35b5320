// Graph executor: binds each layer once (kernel function pointer + arguments with arena pointers),
// then run() is a loop of indirect calls. Convolutions take the best variant of their family's
// table (nn/conv_kernels.h) that the CPU, EF_ISA and ExecutorOptions::max_isa allow, with weights
// repacked for it at creation; every other layer type (add, concat, clamp, max / avg pool, nearest /
// bilinear upsampling, bilinear resize, softmax) likewise from its table in nn/eltwise_kernels.h.
// Tables a layer reads at run time (multipliers, softmax exp table, resize taps) are the Model's,
// computed by the loader: binding allocates nothing per layer beyond the steps.
#include "nn/executor.h"

#include <cmath>
#include <cstring>

#include "nn/eltwise_kernels.h"

namespace ef::nn {

struct Executor::Step {
  LayerType type;
  const char* variant_name = nullptr;  // the row of the layer's variant table
  const kernels::KernelVariant<ConvKernelPtr>* conv = nullptr;
  AddI8Fn add = nullptr;
  ConcatI8Fn concat = nullptr;
  ClampI8Fn clamp = nullptr;
  PoolI8Fn pool = nullptr;
  UpsampleI8Fn upsample = nullptr;
  ResizeI8Fn resize = nullptr;
  SoftmaxI8Fn softmax = nullptr;
  ConvArgs conv_args;
  AddArgs add_args;
  ConcatArgs concat_args;
  ClampArgs clamp_args;
  PoolArgs pool_args;
  UpsampleArgs upsample_args;
  ResizeArgs resize_args;
  SoftmaxArgs softmax_args;
};

Executor::Executor(const Model& model, MemoryPlan plan, const ExecutorOptions& options)
    : model_(model), plan_(std::move(plan)), options_(options) {}
Executor::~Executor() = default;

namespace {

// The best row of `table` that the CPU (capped by EF_ISA) runs and that is at most `max_isa`
// (enum order; rows are lowest ISA first and row 0 is the scalar reference).
template <class Fn, std::size_t N>
const kernels::KernelVariant<Fn>* pick(const kernels::KernelVariant<Fn> (&table)[N], kernels::Isa max_isa) {
  const kernels::KernelVariant<Fn>* best = &table[0];
  for (const auto& v : table)
    if (kernels::isa_available(v.isa) && static_cast<int>(v.isa) <= static_cast<int>(max_isa)) best = &v;
  return best;
}

ConvShape conv_shape(const ModelDesc& d, const LayerDesc& l) {
  const TensorDesc& in = d.tensors[l.inputs[0]];
  const TensorDesc& out = d.tensors[l.output];
  return ConvShape{int(in.c), int(out.c), int(l.kernel_h), int(l.kernel_w), in.zero_point};
}

bool is_conv(LayerType t) {
  return t == LayerType::kConv2d || t == LayerType::kDepthwiseConv2d || t == LayerType::kPointwiseConv2d;
}

// The convolution variant a layer of type `t` runs under `max_isa` (bind() and packed_bytes_for()).
const kernels::KernelVariant<ConvKernelPtr>* conv_variant(LayerType t, kernels::Isa max_isa) {
  return t == LayerType::kDepthwiseConv2d ? pick(kDwConvI8Variants, max_isa) : pick(kConvI8Variants, max_isa);
}

}  // namespace

std::size_t Executor::packed_bytes_for(const Model& model, const ExecutorOptions& options) {
  const ModelDesc& d = model.desc;
  std::size_t total = Arena::kMaxAlign;
  for (const LayerDesc& l : d.layers)
    if (is_conv(l.type)) total += (conv_variant(l.type, options.max_isa)->fn->packed_bytes(conv_shape(d, l)) + 63) / 64 * 64;
  return total;
}

const char* Executor::kernel_name(std::size_t layer) const {
  return layer < steps_.size() && steps_[layer].variant_name ? steps_[layer].variant_name : "";
}

Result<std::unique_ptr<Executor>> Executor::create(const Model& model, const ExecutorOptions& options) {
  EF_ASSIGN_OR_RETURN(MemoryPlan plan, plan_memory(model, options.plan));
  std::unique_ptr<Executor> ex(new Executor(model, std::move(plan), options));
  ex->arena_ = std::make_unique<Arena>(ex->plan_.total_bytes == 0 ? Arena::kMaxAlign : ex->plan_.total_bytes);
  ex->base_ = static_cast<int8_t*>(ex->arena_->allocate_bytes(ex->arena_->capacity(), Arena::kMaxAlign));
  if (ex->base_ == nullptr) return error(ErrorCode::kResourceExhausted, model.source + ": executor: arena allocation failed");
  EF_RETURN_IF_ERROR(ex->bind());
  EF_RETURN_IF_ERROR(ex->pack_weights());
  return ex;
}

Status Executor::pack_weights() {
  const ModelDesc& d = model_.desc;
  packed_ = std::make_unique<Arena>(packed_bytes_for(model_, options_));
  for (std::size_t li = 0; li < steps_.size(); ++li) {
    Step& s = steps_[li];
    if (!s.conv) continue;
    const ConvShape shape = conv_shape(d, d.layers[li]);
    const std::size_t bytes = s.conv->fn->packed_bytes(shape);
    if (bytes == 0) continue;  // the reference reads the file layout
    void* blob = packed_->allocate_bytes(bytes, 64);
    if (blob == nullptr) return error(ErrorCode::kInternal, model_.source + ": executor: packed weight arena too small");
    const PreparedLayer& p = model_.prepared[li];
    s.conv->fn->pack(shape, ConvParams{p.packed.data(), p.bias.data(), p.requant.data()}, blob);
    s.conv_args.packed = blob;
  }
  return {};
}

const int8_t* Executor::tensor_data(uint32_t id) const {
  if (id >= plan_.offset.size() || plan_.offset[id] == MemoryPlan::kNotInArena) return nullptr;
  return base_ + plan_.offset[id];
}

Status Executor::bind() {
  const ModelDesc& d = model_.desc;
  auto view = [&](uint32_t id) {
    const TensorDesc& t = d.tensors[id];
    return TensorI8{base_ + plan_.offset[id], int(t.h), int(t.w), int(t.c), t.zero_point};
  };
  auto mut_view = [&](uint32_t id) {
    const TensorDesc& t = d.tensors[id];
    return MutTensorI8{base_ + plan_.offset[id], int(t.h), int(t.w), int(t.c), t.zero_point};
  };
  const TensorDesc& in = d.tensors[d.input_tensor];
  input_elems_ = static_cast<std::size_t>(in.elements());
  output_elems_ = static_cast<std::size_t>(d.tensors[d.output_tensor].elements());
  input_mul_.resize(in.c);
  for (uint32_t c = 0; c < in.c; ++c) input_mul_[c] = double(d.input_scale[c]) / double(in.scale);

  steps_.resize(d.layers.size());
  for (std::size_t li = 0; li < d.layers.size(); ++li) {
    const LayerDesc& l = d.layers[li];
    const PreparedLayer& p = model_.prepared[li];
    Step& s = steps_[li];
    s.type = l.type;
    // Every int8 tensor a layer touches must have been placed.
    for (uint32_t t : l.inputs)
      if (plan_.offset[t] == MemoryPlan::kNotInArena)
        return error(ErrorCode::kInternal, model_.source + ": executor: layer " + std::to_string(li) + " input not planned");
    if (l.type != LayerType::kSoftmax && plan_.offset[l.output] == MemoryPlan::kNotInArena)
      return error(ErrorCode::kInternal, model_.source + ": executor: layer " + std::to_string(li) + " output not planned");
    switch (l.type) {
      case LayerType::kConv2d:
      case LayerType::kDepthwiseConv2d:
      case LayerType::kPointwiseConv2d: {
        s.conv = conv_variant(l.type, options_.max_isa);
        s.variant_name = s.conv->name;
        ConvArgs& a = s.conv_args;
        a.in = view(l.inputs[0]);
        a.out = mut_view(l.output);
        a.kernel_h = int(l.kernel_h); a.kernel_w = int(l.kernel_w);
        a.stride_h = int(l.stride_h); a.stride_w = int(l.stride_w);
        a.dilation_h = int(l.dilation_h); a.dilation_w = int(l.dilation_w);
        a.pad_top = int(l.pad_top); a.pad_left = int(l.pad_left);
        a.weights = p.packed.data(); a.bias = p.bias.data(); a.requant = p.requant.data();
        a.out_min = l.out_min; a.out_max = l.out_max;
        break;
      }
      case LayerType::kAdd: {
        const auto* v = pick(kAddI8Variants, options_.max_isa);
        s.add = v->fn;
        s.variant_name = v->name;
        s.add_args.a = view(l.inputs[0]);
        s.add_args.b = view(l.inputs[1]);
        s.add_args.out = mut_view(l.output);
        s.add_args.rq_a = p.requant[0];
        s.add_args.rq_b = p.requant[1];
        s.add_args.out_min = l.out_min; s.add_args.out_max = l.out_max;
        break;
      }
      case LayerType::kConcat: {
        const auto* v = pick(kConcatI8Variants, options_.max_isa);
        s.concat = v->fn;
        s.variant_name = v->name;
        s.concat_args.count = int(l.inputs.size());
        for (std::size_t k = 0; k < l.inputs.size(); ++k) {
          s.concat_args.in[k] = view(l.inputs[k]);
          s.concat_args.rq[k] = p.requant[k];
        }
        s.concat_args.out = mut_view(l.output);
        break;
      }
      case LayerType::kClamp: {
        const auto* v = pick(kClampI8Variants, options_.max_isa);
        s.clamp = v->fn;
        s.variant_name = v->name;
        s.clamp_args.in = view(l.inputs[0]);
        s.clamp_args.out = mut_view(l.output);
        s.clamp_args.out_min = l.out_min; s.clamp_args.out_max = l.out_max;
        break;
      }
      case LayerType::kMaxPool:
      case LayerType::kAvgPool: {
        const auto* v = l.type == LayerType::kMaxPool ? pick(kMaxPoolI8Variants, options_.max_isa)
                                                      : pick(kAvgPoolI8Variants, options_.max_isa);
        s.pool = v->fn;
        s.variant_name = v->name;
        s.pool_args.in = view(l.inputs[0]);
        s.pool_args.out = mut_view(l.output);
        s.pool_args.kernel_h = int(l.kernel_h); s.pool_args.kernel_w = int(l.kernel_w);
        s.pool_args.stride_h = int(l.stride_h); s.pool_args.stride_w = int(l.stride_w);
        s.pool_args.pad_top = int(l.pad_top); s.pool_args.pad_left = int(l.pad_left);
        s.pool_args.requant_by_count = p.requant.data();
        // A global pool's table holds its one count, kh*kw (model_format.h PreparedLayer::requant).
        s.pool_args.requant_count_base = is_global_pool(l, d.tensors[l.inputs[0]]) ? int(l.kernel_h * l.kernel_w) : 1;
        break;
      }
      case LayerType::kUpsample: {
        const auto* v = l.mode == UpsampleMode::kNearest ? pick(kUpsampleNearestI8Variants, options_.max_isa)
                                                         : pick(kUpsampleBilinearI8Variants, options_.max_isa);
        s.upsample = v->fn;
        s.variant_name = v->name;
        s.upsample_args.in = view(l.inputs[0]);
        s.upsample_args.out = mut_view(l.output);
        s.upsample_args.factor = int(l.factor);
        break;
      }
      case LayerType::kResizeBilinear: {
        const auto* v = pick(kResizeBilinearI8Variants, options_.max_isa);
        s.resize = v->fn;
        s.variant_name = v->name;
        s.resize_args.in = view(l.inputs[0]);
        s.resize_args.out = mut_view(l.output);
        s.resize_args.taps_y = p.resize_taps.data();                 // out.h entries
        s.resize_args.taps_x = p.resize_taps.data() + s.resize_args.out.h;  // out.w entries
        break;
      }
      case LayerType::kSoftmax: {
        const auto* v = pick(kSoftmaxI8Variants, options_.max_isa);
        s.softmax = v->fn;
        s.variant_name = v->name;
        s.softmax_args.in = view(l.inputs[0]);
        s.softmax_args.exp_table = p.exp_table.data();
        break;
      }
    }
  }
  return {};
}

void Executor::quantize_input(const float* input) {
  // q = clamp(zp + round_half_away((double(v) - mean) * (scale / s_in)), -128, 127); NaN -> zp.
  const TensorDesc& in = model_.desc.tensors[model_.desc.input_tensor];
  int8_t* q = base_ + plan_.offset[model_.desc.input_tensor];
  const std::size_t c = in.c;
  for (std::size_t i = 0; i < input_elems_; ++i) {
    const std::size_t ch = i % c;
    const double t = (double(input[i]) - double(model_.desc.input_mean[ch])) * input_mul_[ch];
    double r = std::isnan(t) ? 0.0 : std::round(t) + in.zero_point;
    r = r < -128.0 ? -128.0 : (r > 127.0 ? 127.0 : r);
    q[i] = static_cast<int8_t>(r);
  }
}

// One convolution, split by output rows over the pool's threads when there is one: each task runs
// the kernel on a copy of the arguments with its own row range (a few hundred bytes on the stack).
void Executor::run_conv(Step& s) {
  const ConvI8Fn run = s.conv->fn->run;
  ThreadPool* pool = options_.pool;
  const int rows = s.conv_args.out.h;
  if (pool == nullptr || pool->threads() == 1 || rows < 2) {
    run(s.conv_args);
    return;
  }
  const int tasks = pool->threads() < rows ? pool->threads() : rows;
  pool->parallel_for(tasks, [&](int task, int) {
    ConvArgs a = s.conv_args;
    split_rows(rows, tasks, task, &a.oy_begin, &a.oy_end);
    run(a);
  });
}

void Executor::run_layers(float* probs) {
  for (Step& s : steps_) {
    switch (s.type) {
      case LayerType::kConv2d:
      case LayerType::kDepthwiseConv2d:
      case LayerType::kPointwiseConv2d: run_conv(s); break;
      case LayerType::kAdd: s.add(s.add_args); break;
      case LayerType::kConcat: s.concat(s.concat_args); break;
      case LayerType::kClamp: s.clamp(s.clamp_args); break;
      case LayerType::kMaxPool:
      case LayerType::kAvgPool: s.pool(s.pool_args); break;
      case LayerType::kUpsample: s.upsample(s.upsample_args); break;
      case LayerType::kResizeBilinear: s.resize(s.resize_args); break;
      case LayerType::kSoftmax:
        s.softmax_args.out = probs;
        s.softmax(s.softmax_args);
        break;
    }
  }
}

Status Executor::run(const float* input, std::size_t input_floats, float* probs, std::size_t probs_floats) {
  if (input == nullptr || input_floats != input_elems_ || probs == nullptr || probs_floats != output_elems_)
    return error(ErrorCode::kInvalidArgument, model_.source + ": run: input needs " + std::to_string(input_elems_) +
                                                  " floats and output " + std::to_string(output_elems_) + " floats");
  quantize_input(input);
  run_layers(probs);
  return {};
}

Status Executor::run_quantized(const int8_t* input_q, std::size_t input_bytes, float* probs, std::size_t probs_floats) {
  if (input_q == nullptr || input_bytes != input_elems_ || probs == nullptr || probs_floats != output_elems_)
    return error(ErrorCode::kInvalidArgument, model_.source + ": run_quantized: input needs " + std::to_string(input_elems_) +
                                                  " bytes and output " + std::to_string(output_elems_) + " floats");
  std::memcpy(base_ + plan_.offset[model_.desc.input_tensor], input_q, input_elems_);
  run_layers(probs);
  return {};
}

}  // namespace ef::nn
