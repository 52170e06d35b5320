// libFuzzer target for the .efm loader. Input: the file bytes (tried as is, then with its CRC
// fixed). A model that loads is also planned and run once on a zero image, so the validator's
// promises (shapes, indices, sizes) are exercised by the executor too; any crash, sanitizer report
// or hang is a bug.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "nn/executor.h"
#include "nn/model_format.h"

namespace {

void load_and_run(const uint8_t* data, size_t size) {
  auto model = ef::nn::load_model_memory(data, size, "fuzz.efm");
  if (!model.ok()) return;
  // Keep each run cheap: skip models with more than ~2^24 multiply-adds (window sizes times outputs).
  uint64_t work = 0;
  for (const auto& l : model->desc.layers) {
    const auto& out = model->desc.tensors[l.output];
    uint64_t per = uint64_t{l.kernel_h} * l.kernel_w * (l.type == ef::nn::LayerType::kConv2d ? model->desc.tensors[l.inputs[0]].c : 1);
    if (l.type == ef::nn::LayerType::kPointwiseConv2d) per = model->desc.tensors[l.inputs[0]].c;
    work += out.elements() * (per + l.inputs.size());
  }
  if (work > (uint64_t{1} << 24)) return;
  auto ex = ef::nn::Executor::create(*model);
  if (!ex.ok()) return;
  // And with large tensors.
  if ((*ex)->arena_bytes() > (1u << 20) || (*ex)->output_floats() > (1u << 18)) return;
  std::vector<float> in((*ex)->input_floats(), 0.0f), out((*ex)->output_floats());
  (void)(*ex)->run(in.data(), in.size(), out.data(), out.size());
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  // As given: exercises the header and CRC checks.
  load_and_run(data, size);
  // With the header's payload CRC made correct, so that mutations reach the section parser and the
  // validator instead of stopping at the CRC.
  if (size >= ef::nn::kEfmHeaderBytes) {
    std::vector<uint8_t> fixed(data, data + size);
    const uint32_t crc = ef::nn::crc32(fixed.data() + ef::nn::kEfmHeaderBytes, size - ef::nn::kEfmHeaderBytes);
    for (int i = 0; i < 4; ++i) fixed[12 + i] = static_cast<uint8_t>(crc >> (8 * i));
    load_and_run(fixed.data(), fixed.size());
  }
  return 0;
}
