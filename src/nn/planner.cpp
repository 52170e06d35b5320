// Liveness-based arena planning. Lifetimes are inclusive layer intervals [first_use, last_use]: a
// layer reads its inputs while it writes its output, so intervals that touch conflict. Buffers
// (a tensor, or a chain of tensors computed in place) are placed in order of first use at the
// lowest aligned offset that does not overlap any already placed buffer live at the same time
// (first fit). This is the greedy heuristic of TFLite's arena planner; optimal packing is NP-hard
// and unnecessary for chain-like CNNs.
#include "nn/planner.h"

#include <algorithm>

namespace ef::nn {

Result<MemoryPlan> plan_memory(const Model& model, const PlanOptions& opt) {
  const ModelDesc& d = model.desc;
  const std::size_t nt = d.tensors.size();
  const std::size_t align = opt.alignment == 0 ? 1 : opt.alignment;
  MemoryPlan plan;
  plan.offset.assign(nt, MemoryPlan::kNotInArena);
  plan.bytes.assign(nt, 0);
  plan.first_use.assign(nt, -2);  // -2: never produced
  plan.last_use.assign(nt, -2);

  plan.first_use[d.input_tensor] = -1;
  for (std::size_t li = 0; li < d.layers.size(); ++li) plan.first_use[d.layers[li].output] = int(li);
  for (std::size_t t = 0; t < nt; ++t) plan.last_use[t] = plan.first_use[t];
  for (std::size_t li = 0; li < d.layers.size(); ++li)
    for (uint32_t t : d.layers[li].inputs) plan.last_use[t] = std::max(plan.last_use[t], int(li));

  // Buffers: tensor -> buffer index; a buffer's interval is the union of its tensors' lifetimes.
  struct Buffer { int start, end; std::size_t bytes; std::size_t offset = 0; };
  std::vector<Buffer> buffers;
  std::vector<int> buffer_of(nt, -1);
  auto in_arena = [&](std::size_t t) { return plan.first_use[t] != -2 && d.tensors[t].dtype == DType::kInt8; };
  auto aligned_size = [&](std::size_t t) {
    const std::size_t b = static_cast<std::size_t>(d.tensors[t].elements());
    return (b + align - 1) / align * align;
  };
  if (in_arena(d.input_tensor)) {
    buffer_of[d.input_tensor] = 0;
    buffers.push_back({-1, plan.last_use[d.input_tensor], aligned_size(d.input_tensor)});
  }
  for (std::size_t li = 0; li < d.layers.size(); ++li) {
    const LayerDesc& l = d.layers[li];
    const std::size_t out = l.output;
    if (!in_arena(out)) continue;
    int reuse = -1;
    if (opt.in_place && (l.type == LayerType::kAdd || l.type == LayerType::kClamp)) {
      for (uint32_t t : l.inputs) {
        const int b = buffer_of[t];
        // The input dies here and no other tensor of its buffer lives on: same size (same shape).
        if (b >= 0 && plan.last_use[t] == int(li) && buffers[b].end == int(li) && buffers[b].bytes == aligned_size(out)) {
          reuse = b;
          break;
        }
      }
    }
    if (reuse >= 0) {
      buffer_of[out] = reuse;
      buffers[reuse].end = plan.last_use[out];
      ++plan.in_place_count;
    } else {
      buffer_of[out] = int(buffers.size());
      buffers.push_back({int(li), plan.last_use[out], aligned_size(out)});
    }
  }

  // Place buffers (already in order of first use).
  std::vector<int> placed;
  std::size_t next_free = 0;  // without reuse: buffers one after another
  for (std::size_t b = 0; b < buffers.size(); ++b) {
    Buffer& buf = buffers[b];
    std::size_t offset = 0;
    if (opt.reuse) {
      std::vector<std::pair<std::size_t, std::size_t>> busy;  // [offset, end) of live placed buffers
      for (int p : placed) {
        const Buffer& o = buffers[p];
        if (o.start <= buf.end && buf.start <= o.end) busy.push_back({o.offset, o.offset + o.bytes});
      }
      std::sort(busy.begin(), busy.end());
      for (const auto& [lo, hi] : busy) {
        if (offset + buf.bytes <= lo) break;  // fits in the gap before this one
        offset = std::max(offset, hi);
      }
    } else {
      offset = next_free;
      next_free += buf.bytes;
    }
    buf.offset = offset;
    placed.push_back(int(b));
    plan.total_bytes = std::max(plan.total_bytes, offset + buf.bytes);
  }
  for (std::size_t t = 0; t < nt; ++t) {
    if (buffer_of[t] < 0) continue;
    plan.offset[t] = buffers[buffer_of[t]].offset;
    plan.bytes[t] = static_cast<std::size_t>(d.tensors[t].elements());
    plan.sum_bytes += aligned_size(t);
    if (plan.offset[t] % align != 0) return error(ErrorCode::kInternal, model.source + ": planner: misaligned offset");
  }
  return plan;
}

}  // namespace ef::nn
