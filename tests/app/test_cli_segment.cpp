// `edgefusion segment` and `edgefusion model info|import`, run in-process through run_cli(), with a
// tiny network written to a scratch folder.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include "core/classes.h"
#include "app/cli_test_util.h"
#include "firmware_app/cli.h"
#include "firmware_app/npy_writer.h"
#include "io/image_codec.h"
#include "semantic/segmenter.h"
#include "semantic/semantic_test_util.h"
#include "sources/open_source.h"
#include "test_support.h"

namespace ef::app {
namespace {

namespace fs = std::filesystem;

// Sets an environment variable for one scope and restores the previous state.
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const std::optional<std::string>& value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    if (value) setenv(name, value->c_str(), 1);
    else unsetenv(name);
  }
  ~ScopedEnv() {
    if (old_) setenv(name_, old_->c_str(), 1);
    else unsetenv(name_);
  }

 private:
  const char* name_;
  std::optional<std::string> old_;
};

std::string read_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

TEST(CliSegment, HelpForEveryNewCommand) {
  for (std::vector<std::string> a : {std::vector<std::string>{"segment", "--help"}, {"model", "--help"},
                                     {"model", "info", "--help"}, {"model", "import", "--help"}}) {
    const auto r = cli(a);
    EXPECT_EQ(r.code, 0) << a[0];
    EXPECT_NE(r.out.find("Usage"), std::string::npos) << a[0] << " " << a[1];
  }
  EXPECT_NE(cli({"--help"}).out.find("segment"), std::string::npos);
  EXPECT_EQ(cli({"model"}).code, 2);
  EXPECT_EQ(cli({"model", "summon"}).code, 2);
}

// The three folders with the stems `convert --to tum:` uses, at the source's size, and
// `eval labels` takes them against the converted ground truth.
TEST(CliSegment, WritesLabelsColourAndProbabilitiesThatEvalLabelsAccepts) {
  const auto dir = test::scratch_dir("cli-segment");
  const fs::path model = test::write_tiny_seg_model(dir);
  const std::string uri = "synthetic:?frames=3&size=320x240";
  auto r = cli({"segment", "--model", model.string(), "--source", uri, "--out", (dir / "seg").string(),
                "--probabilities", "--quiet"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("segmented 3 of 3 frames (source 320x240, network input 32x24, output 16x12 x 14 classes)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("forward pass: median"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("kernel ISA"), std::string::npos) << r.out;

  r = cli({"convert", "--source", uri, "--to", "tum:" + (dir / "gt").string(), "--quiet"});
  ASSERT_EQ(r.code, 0) << r.err;

  // The segmenter run directly on the same frames: the files hold its results.
  auto seg = semantic::Segmenter::create(model.string());
  ASSERT_TRUE(seg.ok());
  auto source = open_source(uri);
  ASSERT_TRUE(source.ok());
  Frame f;
  Image<uint8_t> want(320, 240);
  for (int i = 0; i < 3; ++i) {
    ASSERT_TRUE(*(*source)->next(f));
    const std::string stem = f.name;
    SCOPED_TRACE(stem);
    ASSERT_TRUE(fs::exists(dir / "gt" / "labels" / (stem + ".png")));
    ASSERT_TRUE((*seg)->segment(f, want.view()).ok());

    Image<uint8_t> ids;
    ASSERT_TRUE(read_png_u8((dir / "seg" / "labels" / (stem + ".png")).string(), ids).ok());
    ASSERT_EQ(ids.width(), 320);
    ASSERT_EQ(ids.height(), 240);
    EXPECT_EQ(std::memcmp(ids.data(), want.data(), want.size()), 0);

    Image<Rgb8> color;
    ASSERT_TRUE(read_color_image((dir / "seg" / "labels_color" / (stem + ".png")).string(), color).ok());
    ASSERT_EQ(color.width(), 320);
    ASSERT_EQ(color.height(), 240);
    for (int y = 0; y < 240; y += 7)
      for (int x = 0; x < 320; x += 5) ASSERT_EQ(color(x, y), class_color(ids(x, y)));

    // The .npy: a v1.0 header for (12, 16, 14) float32, then exactly the probabilities.
    const std::string npy = read_bytes(dir / "seg" / "probabilities" / (stem + ".npy"));
    const std::size_t shape[3] = {12, 16, 14};
    const std::string header = npy_header_f32(shape, 3);
    ASSERT_EQ(npy.size(), header.size() + 12 * 16 * 14 * sizeof(float));
    EXPECT_EQ(npy.compare(0, header.size(), header), 0);
    EXPECT_EQ(header.size() % 64, 0u);
    EXPECT_NE(header.find("'shape': (12, 16, 14)"), std::string::npos) << header;
    EXPECT_EQ(std::memcmp(npy.data() + header.size(), (*seg)->probabilities().data, 12 * 16 * 14 * sizeof(float)), 0);
  }

  r = cli({"eval", "labels", (dir / "gt" / "labels").string(), (dir / "seg" / "labels").string(), "--depth",
           (dir / "gt" / "depth").string()});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(metric(r.out, "images"), 3) << r.out;
  EXPECT_GT(metric(r.out, "pixels"), 320 * 240);
}

TEST(CliSegment, EveryKthFrameWithoutProbabilities) {
  const auto dir = test::scratch_dir("cli-segment-every");
  const fs::path model = test::write_tiny_seg_model(dir);
  auto r = cli({"segment", "--model", model.string(), "--source", "synthetic:?frames=5&size=160x120", "--out",
                (dir / "seg").string(), "--every", "2", "--isa", "scalar", "--threads", "2", "--quiet"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("segmented 3 of 5 frames"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("kernel ISA scalar"), std::string::npos) << r.out;
  for (const char* stem : {"000000", "000002", "000004"})
    EXPECT_TRUE(fs::exists(dir / "seg" / "labels" / (std::string(stem) + ".png"))) << stem;
  EXPECT_FALSE(fs::exists(dir / "seg" / "labels" / "000001.png"));
  EXPECT_FALSE(fs::exists(dir / "seg" / "probabilities"));

  r = cli({"convert", "--source", "synthetic:?frames=5&size=160x120", "--to", "tum:" + (dir / "gt").string(),
           "--quiet"});
  ASSERT_EQ(r.code, 0) << r.err;
  r = cli({"eval", "labels", (dir / "gt" / "labels").string(), (dir / "seg" / "labels").string(), "--every", "2"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(metric(r.out, "images"), 3) << r.out;
}

TEST(CliSegment, BadOptionsAreNamed) {
  const auto dir = test::scratch_dir("cli-segment-bad");
  const fs::path model = test::write_tiny_seg_model(dir);
  auto r = cli({"segment", "--model", model.string(), "--source", "synthetic:", "--out", dir.string(), "--isa", "avx3"});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("avx3"), std::string::npos) << r.err;
  r = cli({"segment", "--model", model.string(), "--source", "synthetic:", "--out", dir.string(), "--every", "0"});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--every"), std::string::npos) << r.err;
  r = cli({"segment", "--model", model.string(), "--out", dir.string()});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--source"), std::string::npos) << r.err;
}

// A missing model names the path and says how to get one, given or by default.
TEST(CliSegment, MissingModelIsAClearError) {
  const auto dir = test::scratch_dir("cli-segment-missing");
  const std::string missing = (dir / "nope.efm").string();
  auto r = cli({"segment", "--model", missing, "--source", "synthetic:?frames=1", "--out", (dir / "o").string()});
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find(missing), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("models/README.md"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("edgefusion model import"), std::string::npos) << r.err;

  {
    ScopedEnv env("EDGEFUSION_MODEL", missing);
    r = cli({"segment", "--source", "synthetic:?frames=1", "--out", (dir / "o").string()});
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.err.find(missing), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("EDGEFUSION_MODEL"), std::string::npos) << r.err;
  }
  r = cli({"model", "info", missing});
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find(missing), std::string::npos) << r.err;

  // With no override the default is the shipped file under the source tree's models/ (checked only
  // while that file does not exist yet).
  ScopedEnv env("EDGEFUSION_MODEL", std::nullopt);
  const std::string shipped = std::string(EF_SOURCE_DIR) + "/models/edgefusion-seg.efm";
  if (!fs::exists(shipped)) {
    r = cli({"segment", "--source", "synthetic:?frames=1", "--out", (dir / "o").string()});
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.err.find(shipped), std::string::npos) << r.err;
  }
}

TEST(CliModel, InfoPrintsShapesClassesCostsAndKernels) {
  const auto dir = test::scratch_dir("cli-model-info");
  const fs::path model = test::write_tiny_seg_model(dir);
  auto r = cli({"model", "info", model.string()});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("tiny-seg"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("24x32x4"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("12x16x14"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("unknown bed books ceiling chair floor furniture objects painting sofa table tv wall window"),
            std::string::npos)
      << r.out;
  EXPECT_EQ(metric(r.out, "classes"), 14);
  EXPECT_EQ(metric(r.out, "layers"), 3);
  EXPECT_EQ(metric(r.out, "macs"), 12 * 16 * 8 * 3 * 3 * 4 + 12 * 16 * 14 * 8);
  EXPECT_EQ(metric(r.out, "parameters"), (8 * 36 + 8) + (14 * 8 + 14));
  EXPECT_GT(metric(r.out, "arena_bytes"), 0);
  EXPECT_GT(metric(r.out, "packed_weight_bytes"), 0);
  EXPECT_NE(r.out.find("conv_i8"), std::string::npos) << r.out;  // the conv layers' variants
  EXPECT_NE(r.out.find("softmax"), std::string::npos) << r.out;

  r = cli({"model", "info", model.string(), "--isa", "scalar"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("conv_i8_ref"), std::string::npos) << r.out;

  // The layer table's rows line up (issue 33, rough edge 9): the header and every row end at the
  // same column, and each row's MMAC figure sits under the header's "MMAC", whatever the names.
  for (const std::string& shipped : {std::string(EF_SOURCE_DIR) + "/models/deeplabv3-mnv2-nyu13.efm", model.string()}) {
    r = cli({"model", "info", shipped});
    ASSERT_EQ(r.code, 0) << r.err;
    const auto table = r.out.find("\nlayer  ");
    ASSERT_NE(table, std::string::npos) << r.out;
    std::istringstream lines(r.out.substr(table + 1));
    std::string header, line;
    std::getline(lines, header);
    int rows = 0;
    while (std::getline(lines, line) && !line.empty()) {
      EXPECT_EQ(line.size(), header.size()) << shipped << ":\n" << header << "\n" << line;
      ++rows;
    }
    EXPECT_EQ(rows, static_cast<int>(metric(r.out, "layers"))) << shipped;
  }

  std::ofstream(dir / "junk.efm") << "not a model";
  r = cli({"model", "info", (dir / "junk.efm").string()});
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("junk.efm"), std::string::npos) << r.err;
}

// The Python importer is looked for before anything runs; its absence is named with what to install.
TEST(CliModel, ImportWithoutThePythonModuleIsAClearError) {
  const auto dir = test::scratch_dir("cli-model-import");
  fs::create_directories(dir / "empty-models");
  ScopedEnv env("EDGEFUSION_MODELS_DIR", (dir / "empty-models").string());
  auto r = cli({"model", "import", "--onnx", (dir / "net.onnx").string(), "--calibration", "synthetic:?frames=2",
                "--out", (dir / "net.efm").string()});
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("edgefusion_models.import_onnx"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find((dir / "empty-models" / "edgefusion_models" / "import_onnx.py").string()), std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("EDGEFUSION_MODELS_DIR"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("python3-onnx python3-numpy python3-opencv"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "net.efm"));

  r = cli({"model", "import", "--onnx", "x.onnx", "--out", "y.efm"});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--calibration"), std::string::npos) << r.err;
}

// Issue 28: exactly one network format; the TFLite-only options are refused with ONNX.
TEST(CliModel, ImportTakesExactlyOneNetwork) {
  auto r = cli({"model", "import", "--calibration", "synthetic:?frames=2", "--out", "y.efm"});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("give exactly one of --onnx FILE and --tflite FILE"), std::string::npos) << r.err;
  r = cli({"model", "import", "--onnx", "a.onnx", "--tflite", "b.tflite", "--calibration", "synthetic:", "--out", "y.efm"});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("both given"), std::string::npos) << r.err;
  r = cli({"model", "import", "--onnx", "a.onnx", "--input", "257x193", "--calibration", "synthetic:", "--out", "y.efm"});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--input applies to --tflite only"), std::string::npos) << r.err;
}

// With a stand-in module: the arguments and PYTHONPATH it gets, and its exit code comes back.
TEST(CliModel, ImportRunsTheModuleAndReturnsItsExitCode) {
  if (access("/usr/bin/python3", X_OK) != 0) GTEST_SKIP() << "no /usr/bin/python3";
  const auto dir = test::scratch_dir("cli-model-import-fake");
  fs::create_directories(dir / "models" / "edgefusion_models");
  std::ofstream(dir / "models" / "edgefusion_models" / "import_onnx.py")
      << "import os, sys\n"
         "here = os.path.dirname(os.path.abspath(__file__))\n"
         "with open(os.path.join(here, 'args.txt'), 'w') as f:\n"
         "    f.write('\\n'.join(sys.argv[1:]) + '\\n' + os.environ['PYTHONPATH'] + '\\n')\n"
         "sys.exit(7)\n";
  ScopedEnv env("EDGEFUSION_MODELS_DIR", (dir / "models").string());
  const auto r = cli({"model", "import", "--onnx", "net.onnx", "--calibration", "synthetic:?frames=2", "--out",
                      "net.efm", "--frames", "4"});
  if (r.err.find(" lacks ") != std::string::npos) GTEST_SKIP() << r.err;  // python3-onnx etc. not installed
  EXPECT_EQ(r.code, 7) << r.err;
  std::istringstream args(read_bytes(dir / "models" / "edgefusion_models" / "args.txt"));
  std::vector<std::string> lines;
  for (std::string line; std::getline(args, line);) lines.push_back(line);
  ASSERT_EQ(lines.size(), 11u) << read_bytes(dir / "models" / "edgefusion_models" / "args.txt");
  const std::vector<std::string> want = {"--onnx", "net.onnx", "--calibration", "synthetic:?frames=2", "--out",
                                         "net.efm", "--edgefusion"};
  for (std::size_t i = 0; i < want.size(); ++i) EXPECT_EQ(lines[i], want[i]) << i;
  EXPECT_TRUE(fs::exists(lines[7])) << lines[7];  // this executable, from /proc/self/exe
  EXPECT_EQ(lines[8], "--frames");
  EXPECT_EQ(lines[9], "4");
  EXPECT_EQ(lines[10].substr(0, (dir / "models").string().size()), (dir / "models").string()) << lines[10];
}

}  // namespace
}  // namespace ef::app
