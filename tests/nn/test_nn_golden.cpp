// Whole-network bit-exactness against the Python exporter (models/edgefusion_models/): the exporter's
// numpy integer reference (int8_ref.py) wrote golden files next to each model, and the executor must
// reproduce them byte for byte with every kernel variant the CPU runs, with and without a thread pool,
// natively and under qemu-aarch64 (QEMU_CPU=cortex-a53 and max in .ci/run).
//
// Golden directory (models/edgefusion_models/golden.py): input_q.bin (the int8 input tensor),
// output_rows.bin (float32 probabilities of a few rows) and manifest.txt, whose records give the
// CRC32 of the full float32 output, of the model file and of every int8 tensor. The full output
// (120 x 160 x 14 floats) is checked through its CRC32 and the stored rows exactly; the per-tensor
// CRCs name the first layer that differs when something breaks.
//
// Fixtures: tests/data/nn/random_edgesegnet/ (a random EdgeSegNet, `python3 -m edgefusion_models.export
// --random-init 1`; regenerate with that command, models/tests/test_determinism.py checks it is
// reproducible), the shipped models/edgefusion-seg.efm with models/golden/ and the shipped
// models/deeplabv3-mnv2-nyu13.efm with models/golden-deeplab/ (257 x 193 x 151 before the class map).
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include "core/thread_pool.h"
#include "kernels/variants.h"
#include "nn/executor.h"
#include "nn/model_format.h"
#include "test_support.h"

namespace ef::nn {
namespace {

namespace fs = std::filesystem;

struct GoldenTensor {
  uint32_t id = 0, h = 0, w = 0, c = 0, crc = 0;
  std::string name;
};

struct Golden {
  std::string description;
  uint32_t model_crc = 0;
  std::size_t model_bytes = 0;
  std::string input_file;
  uint32_t in_h = 0, in_w = 0, in_c = 0;
  uint32_t out_h = 0, out_w = 0, out_c = 0, output_crc = 0;
  std::string rows_file;
  std::vector<int> rows;
  std::vector<GoldenTensor> tensors;
};

bool read_bytes(const fs::path& p, std::string* out) {
  std::ifstream f(p, std::ios::binary);
  if (!f) return false;
  out->assign(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
  return true;
}

uint32_t hex32(const std::string& s) { return static_cast<uint32_t>(std::stoul(s, nullptr, 16)); }

// "key values..." lines; '#' starts a comment line (golden.py writes the format).
::testing::AssertionResult parse_manifest(const fs::path& dir, Golden* g) {
  std::ifstream f(dir / "manifest.txt");
  if (!f) return ::testing::AssertionFailure() << "cannot read " << (dir / "manifest.txt");
  std::string line;
  bool has_input = false, has_output = false, has_rows = false;
  while (std::getline(f, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream in(line);
    std::string key, tag, crc;
    in >> key;
    if (key == "format") {
      int v = 0;
      in >> v;
      if (v != 1) return ::testing::AssertionFailure() << "manifest format " << v << ", this test reads 1";
    } else if (key == "description") {
      std::getline(in, g->description);
    } else if (key == "model_crc32") {
      in >> crc >> g->model_bytes;
      g->model_crc = hex32(crc);
    } else if (key == "input") {
      has_input = static_cast<bool>(in >> g->input_file >> g->in_h >> g->in_w >> g->in_c);
    } else if (key == "output") {
      has_output = static_cast<bool>(in >> g->out_h >> g->out_w >> g->out_c >> tag >> crc) && tag == "crc32";
      if (has_output) g->output_crc = hex32(crc);
    } else if (key == "rows") {
      in >> g->rows_file;
      for (int r; in >> r;) g->rows.push_back(r);
      has_rows = !g->rows.empty();
    } else if (key == "tensor") {
      GoldenTensor t;
      if (!(in >> t.id >> t.h >> t.w >> t.c >> tag >> crc) || tag != "crc32")
        return ::testing::AssertionFailure() << "bad manifest line: " << line;
      t.crc = hex32(crc);
      in >> t.name;
      g->tensors.push_back(t);
    }
  }
  if (!has_input || !has_output || !has_rows)
    return ::testing::AssertionFailure() << dir << ": manifest lacks the input, output or rows record";
  return ::testing::AssertionSuccess();
}

// Under qemu-user (test::kUnderEmulator) every cap runs too, the scalar one included (the reference
// layers as the target's compiler builds them), but on one thread and with one plan only: the
// pool's row split and the arena's reuse are the same C++ on every architecture, are checked
// natively, and qemu's x86 host would not show a weak-memory race anyway. A forward pass there
// costs about 0.2 s for the 120x160 networks and 2.4-5 s for the 257x193 DeepLab (printed per cap).
// The skip this test once had under qemu ("over 10 minutes, cause not yet found") was qemu run with
// -L /usr/aarch64-linux-gnu (or QEMU_LD_PREFIX set): the cross toolchain's ld.so (Debian glibc
// 2.36-8) then loads the multiarch libc.so.6 (2.36-9+deb12u*), and the first pthread_create (this
// test's pool) loops for ever in libc's walk of the thread stack cache, a list kept in the other
// build's _rtld_global. toolchains/aarch64-linux-gnu.cmake passes -L / so that this cannot recur.
// In the sanitizer builds (test::kUnderSanitizer) only the best cap runs, on one thread and on
// three: the whole network through every cap is the release build's test (and qemu's), each
// variant meets the sanitizers in the per-kernel variant tests, and what TSan is for here is the
// pool's row split (the scalar cap of the DeepLab network alone took 5 minutes under TSan).
using test::kUnderEmulator;

std::vector<ExecutorOptions> variant_options(ThreadPool* pool) {
  std::vector<ExecutorOptions> out;
  kernels::Isa best = kernels::Isa::scalar;
  for (kernels::Isa isa : {kernels::Isa::scalar, kernels::Isa::sse41, kernels::Isa::avx2, kernels::Isa::avxvnni,
                           kernels::Isa::avx512vnni, kernels::Isa::neon, kernels::Isa::neondot})
    if (kernels::isa_available(isa)) best = isa;
  for (kernels::Isa isa : {kernels::Isa::scalar, kernels::Isa::sse41, kernels::Isa::avx2, kernels::Isa::avxvnni,
                           kernels::Isa::avx512vnni, kernels::Isa::neon, kernels::Isa::neondot}) {
    if (!kernels::isa_available(isa)) continue;
    if (test::kUnderSanitizer && isa != best) continue;
    ExecutorOptions o;
    o.max_isa = isa;
    out.push_back(o);
    if (kUnderEmulator) continue;
    o.pool = pool;  // the same variants with convolutions split by rows over three threads
    out.push_back(o);
  }
  return out;
}

void check_golden(const fs::path& model_path, const fs::path& dir) {
  Golden g;
  ASSERT_TRUE(parse_manifest(dir, &g));
  SCOPED_TRACE("golden " + dir.string() + ":" + g.description);
  std::string file;
  ASSERT_TRUE(read_bytes(model_path, &file)) << model_path;
  ASSERT_EQ(file.size(), g.model_bytes) << model_path << " is not the model the golden files were made from";
  ASSERT_EQ(crc32(file.data(), file.size()), g.model_crc) << model_path << " is not the model the golden files were made from";
  auto model = load_model(model_path.string());
  ASSERT_TRUE(model.ok()) << to_string(model.error());

  // The Python writer lays the bytes out as the C++ writer does.
  auto again = serialize_model(model->desc);
  ASSERT_TRUE(again.ok()) << to_string(again.error());
  EXPECT_TRUE(*again == file) << "serialize_model(load_model(f)) differs from the exporter's bytes";

  std::string input, rows;
  ASSERT_TRUE(read_bytes(dir / g.input_file, &input));
  ASSERT_TRUE(read_bytes(dir / g.rows_file, &rows));
  const std::size_t row_floats = std::size_t(g.out_w) * g.out_c;
  ASSERT_EQ(input.size(), std::size_t(g.in_h) * g.in_w * g.in_c);
  ASSERT_EQ(rows.size(), g.rows.size() * row_floats * sizeof(float));
  const TensorDesc& tin = model->desc.tensors[model->desc.input_tensor];
  const TensorDesc& tout = model->desc.tensors[model->desc.output_tensor];
  ASSERT_EQ(std::vector<uint32_t>({tin.h, tin.w, tin.c}), std::vector<uint32_t>({g.in_h, g.in_w, g.in_c}));
  ASSERT_EQ(std::vector<uint32_t>({tout.h, tout.w, tout.c}), std::vector<uint32_t>({g.out_h, g.out_w, g.out_c}));
  const auto* input_q = reinterpret_cast<const int8_t*>(input.data());

  // Every intermediate tensor, with each variant (no arena reuse: all tensors stay readable).
  ThreadPoolOptions po;
  po.threads = 3;
  auto pool = ThreadPool::create(po);
  ASSERT_TRUE(pool.ok()) << to_string(pool.error());
  for (ExecutorOptions o : variant_options(pool->get())) {
    std::string variant = std::string("cap ") + kernels::isa_name(o.max_isa) + (o.pool ? ", 3 threads" : ", 1 thread");
    SCOPED_TRACE(variant);
    std::string kernels_used;
    double pass_ms = 0;  // wall time of the first forward pass (printed: the cost under qemu-user)
    for (bool reuse : {false, true}) {
      if (reuse && kUnderEmulator) break;  // one plan per option under qemu (see kUnderEmulator)
      o.plan = PlanOptions{reuse, reuse, 64};
      auto ex = Executor::create(*model, o);
      ASSERT_TRUE(ex.ok()) << to_string(ex.error());
      std::vector<float> probs((*ex)->output_floats());
      const auto t0 = std::chrono::steady_clock::now();
      ASSERT_TRUE((*ex)->run_quantized(input_q, input.size(), probs.data(), probs.size()).ok());
      if (!reuse) pass_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      if (!reuse) {
        // The variants this cap picked, e.g. "conv_i8__avx2 dwconv_i8__avx2" (what the run covered).
        for (std::size_t l = 0; l < model->desc.layers.size(); ++l) {
          const std::string k = (*ex)->kernel_name(l);
          if (!k.empty() && kernels_used.find(k) == std::string::npos) kernels_used += " " + k;
        }
        for (const GoldenTensor& t : g.tensors) {
          ASSERT_LT(t.id, model->desc.tensors.size());
          const int8_t* data = (*ex)->tensor_data(t.id);
          ASSERT_NE(data, nullptr) << "tensor " << t.id;
          const std::size_t n = model->desc.tensors[t.id].elements();
          ASSERT_EQ(n, std::size_t(t.h) * t.w * t.c) << "tensor " << t.id;
          // The first tensor that differs names the layer at fault; stop there.
          ASSERT_EQ(crc32(data, n), t.crc) << "int8 tensor " << t.id << " (" << t.name << ") differs from the exporter's";
        }
      }
      EXPECT_EQ(crc32(probs.data(), probs.size() * sizeof(float)), g.output_crc) << "probabilities differ";
      for (std::size_t k = 0; k < g.rows.size(); ++k) {
        const float* want = reinterpret_cast<const float*>(rows.data()) + k * row_floats;
        const float* got = probs.data() + std::size_t(g.rows[k]) * row_floats;
        EXPECT_EQ(std::memcmp(want, got, row_floats * sizeof(float)), 0) << "probabilities of row " << g.rows[k] << " differ";
      }
    }
    std::printf("[ golden ] %s: %s bit-exact (%s ), one forward pass %.1f ms\n", model_path.filename().string().c_str(),
                variant.c_str(), kernels_used.c_str(), pass_ms);
  }
}

TEST(NnGolden, RandomEdgeSegNetFixture) {
  const fs::path dir = fs::path(EF_SOURCE_DIR) / "tests" / "data" / "nn" / "random_edgesegnet";
  check_golden(dir / "model.efm", dir);
}

TEST(NnGolden, ShippedModel) {
  const fs::path model = fs::path(EF_SOURCE_DIR) / "models" / "edgefusion-seg.efm";
  const fs::path dir = fs::path(EF_SOURCE_DIR) / "models" / "golden";
  std::error_code ec;
  if (!fs::exists(model, ec) || !fs::exists(dir / "manifest.txt", ec))
    GTEST_SKIP() << "no shipped model yet (" << model << " and " << dir / "manifest.txt"
                 << "): it comes with the training run; export it with python3 -m edgefusion_models.export";
  check_golden(model, dir);
}

// Issue 28: the real-camera network (DeepLabv3-MobileNetV2 imported from TFLite by
// models/import_deeplab.sh): dilated depthwise convolutions, 960-channel 1x1s, a global pool and its
// broadcast, align-corners resizes, concatenations, RGB input and a class map, bit-exact on every ISA.
TEST(NnGolden, ShippedRealCameraModel) {
  const fs::path model = fs::path(EF_SOURCE_DIR) / "models" / "deeplabv3-mnv2-nyu13.efm";
  const fs::path dir = fs::path(EF_SOURCE_DIR) / "models" / "golden-deeplab";
  check_golden(model, dir);
}

}  // namespace
}  // namespace ef::nn
