// libFuzzer target for the .efm loader (nn/model_format.h) and the executor behind it. Input: the
// file bytes (tried as is, then with its CRC fixed). A model that loads and is within the work limit
// below is planned and run once on an image made of the input's bytes, so the validator's promises
// (shapes, indices, sizes) are exercised by the executor too; any crash, sanitizer report or hang is
// a bug. The seeds (tests/fuzz/corpus/model, the corpus tool's tiny model family) are all within
// the limit and together hold every layer type, so mutations land in layer parameters and weights
// and the forward pass runs.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "nn/executor.h"
#include "nn/model_format.h"

namespace {

void load_and_run(const uint8_t* data, size_t size) {
  if (size == 0) return;
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
  // The input image: the file's bytes over and over (colour 0..255, depth in metres 0..2.55).
  std::vector<float> in((*ex)->input_floats()), out((*ex)->output_floats());
  const std::size_t channels = model->desc.tensors[model->desc.input_tensor].c;
  for (std::size_t i = 0; i < in.size(); ++i) {
    const float v = static_cast<float>(data[(i * 7) % size]);
    in[i] = channels == 4 && i % 4 == 3 ? v / 100.0f : v;
  }
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
