// The Python integer reference (models/edgefusion_models/int8_ref.py) and the C++ runtime agree on
// resize_bilinear, a global average pool above kMaxKernel and a version 2 file with a class map: the
// fixture tests/data/nn/resize_pool_cmap/ (models/tests/test_resize_pool_cmap.py writes it from
// helpers.resize_model(); regenerate with `cd models && python3 -m tests.test_resize_pool_cmap --write`)
// holds the model, an int8 input and golden.py's manifest of the CRC32 of every int8 tensor and of the
// float32 probabilities as the Python reference computed them. Every kernel variant, with and without
// a thread pool, must reproduce each one. The network is 17x25 -> 33x33, small enough for qemu.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "core/thread_pool.h"
#include "kernels/variants.h"
#include "nn/executor.h"
#include "nn/model_format.h"

namespace ef::nn {
namespace {

namespace fs = std::filesystem;

const fs::path kDir = fs::path(EF_SOURCE_DIR) / "tests" / "data" / "nn" / "resize_pool_cmap";

std::string read_file(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

// The records of manifest.txt this test needs (golden.py writes the format): the model's CRC, the
// output's CRC, and tensor id -> CRC.
struct Manifest {
  uint32_t model_crc = 0, output_crc = 0;
  std::map<uint32_t, uint32_t> tensor_crc;
};

bool parse(const std::string& text, Manifest* m) {
  std::istringstream in(text);
  bool model = false, output = false;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream r(line);
    std::string key, crc, tag;
    r >> key;
    if (key == "model_crc32") {
      model = static_cast<bool>(r >> crc);
      m->model_crc = uint32_t(std::stoul(crc, nullptr, 16));
    } else if (key == "output") {
      uint32_t h, w, c;
      output = static_cast<bool>(r >> h >> w >> c >> tag >> crc) && tag == "crc32";
      if (output) m->output_crc = uint32_t(std::stoul(crc, nullptr, 16));
    } else if (key == "tensor") {
      uint32_t id, h, w, c;
      if (!(r >> id >> h >> w >> c >> tag >> crc) || tag != "crc32") return false;
      m->tensor_crc[id] = uint32_t(std::stoul(crc, nullptr, 16));
    }
  }
  return model && output && !m->tensor_crc.empty();
}

TEST(NnResizeGolden, PythonReferenceAndRuntimeAgreeWithEveryVariant) {
  const std::string file = read_file(kDir / "model.efm");
  const std::string input = read_file(kDir / "input_q.bin");
  Manifest g;
  ASSERT_TRUE(parse(read_file(kDir / "manifest.txt"), &g)) << kDir;
  ASSERT_EQ(crc32(file.data(), file.size()), g.model_crc) << "model.efm is not the one the manifest was made from";

  auto model = load_model((kDir / "model.efm").string());
  ASSERT_TRUE(model.ok()) << to_string(model.error());
  const ModelDesc& d = model->desc;
  // What the Python side wrote: a version 2 file with its class map, the layer types under test.
  EXPECT_EQ(d.class_map, std::vector<uint8_t>({0, 1, 1, 2, 3, 3, 0}));
  EXPECT_EQ(d.target_class_names, std::vector<std::string>({"unknown", "wall", "floor", "other"}));
  EXPECT_EQ(d.layers[1].type, LayerType::kResizeBilinear);
  EXPECT_EQ(d.layers[2].type, LayerType::kAvgPool);
  EXPECT_EQ(d.layers[2].kernel_w, 49u);
  auto again = serialize_model(d);
  ASSERT_TRUE(again.ok()) << to_string(again.error());
  EXPECT_TRUE(*again == file) << "serialize_model(load_model(f)) differs from the Python writer's bytes";
  ASSERT_EQ(input.size(), d.tensors[d.input_tensor].elements());

  ThreadPoolOptions po;
  po.threads = 2;
  auto pool = ThreadPool::create(po);
  ASSERT_TRUE(pool.ok());
  for (kernels::Isa isa : {kernels::Isa::scalar, kernels::Isa::sse41, kernels::Isa::avx2, kernels::Isa::avx512vnni,
                           kernels::Isa::neon, kernels::Isa::neondot}) {
    if (!kernels::isa_available(isa)) continue;
    for (ThreadPool* p : {static_cast<ThreadPool*>(nullptr), pool->get()}) {
      SCOPED_TRACE(std::string("cap ") + kernels::isa_name(isa) + (p ? ", 2 threads" : ", 1 thread"));
      ExecutorOptions o;
      o.plan = PlanOptions{false, true, 64};  // no reuse: every tensor readable after the run
      o.max_isa = isa;
      o.pool = p;
      auto ex = Executor::create(*model, o);
      ASSERT_TRUE(ex.ok()) << to_string(ex.error());
      std::vector<float> probs((*ex)->output_floats());
      ASSERT_TRUE((*ex)->run_quantized(reinterpret_cast<const int8_t*>(input.data()), input.size(), probs.data(),
                                       probs.size()).ok());
      for (const auto& [id, crc] : g.tensor_crc) {
        const int8_t* data = (*ex)->tensor_data(id);
        ASSERT_NE(data, nullptr) << "tensor " << id;
        // The first tensor that differs names the layer at fault.
        ASSERT_EQ(crc32(data, d.tensors[id].elements()), crc)
            << "int8 tensor " << id << " differs from the Python reference (layer " << (id ? id - 1 : 0) << ", "
            << (*ex)->kernel_name(id ? id - 1 : 0) << ")";
      }
      EXPECT_EQ(crc32(probs.data(), probs.size() * sizeof(float)), g.output_crc) << "probabilities differ";
    }
  }
}

}  // namespace
}  // namespace ef::nn
