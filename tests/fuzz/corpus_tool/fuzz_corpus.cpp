// Writes the seed corpus of every fuzz target (tests/fuzz/corpus/<target minus fuzz_>/) with our own
// writers, so the fuzzers start from files the product makes and reach the code behind the headers
// (tests/fuzz/make_corpus.sh runs it; tests/fuzz/README.md lists what each seed is for).
//   fuzz_corpus OUT_DIR
// Every seed is small (a few kB at most; tiny synthetic frames) and the same bytes on every run:
// synthetic frames are bit-exact, timestamps come from the frames, and the checkpoints' wall time is
// fixed. Any writer error aborts: a seed the product cannot write is a bug to look at, not to skip.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "checkpoint_setup.h"
#include "core/stage_stats.h"
#include "firmware_app/commands.h"
#include "firmware_app/config_file.h"
#include "fixtures.h"
#include "io/image_codec.h"
#include "io/ply_writer.h"
#include "io/trajectory_io.h"
#include "nn/executor.h"
#include "nn/model_format.h"
#include "nn/nn_test_util.h"
#include "pipeline/checkpoint.h"
#include "pipeline/run_config.h"

namespace fs = std::filesystem;
using namespace ef;
using ef::fuzz::check;

namespace {

fs::path g_out;      // OUT_DIR
fs::path g_scratch;  // the writers' own files, removed at the end

// OUT_DIR/<target>/<name> = prefix + bytes.
void seed(const std::string& target, const std::string& name, const std::string& bytes, const std::string& prefix = "") {
  const fs::path dir = g_out / target;
  fs::create_directories(dir);
  const std::string all = prefix + bytes;
  std::FILE* f = std::fopen((dir / name).c_str(), "wb");
  if (f == nullptr || std::fwrite(all.data(), 1, all.size(), f) != all.size()) {
    std::fprintf(stderr, "fuzz_corpus: cannot write %s\n", (dir / name).c_str());
    std::exit(1);
  }
  std::fclose(f);
}
std::string byte(int v) { return std::string(1, static_cast<char>(v)); }
std::string scratch(const std::string& name) { return (g_scratch / name).string(); }

// ---- Images (fuzz_png, fuzz_jpeg, fuzz_ppm) ----

void image_seeds(const fuzz::Recording& r) {
  const Frame& f = r.frames[0];
  Image<uint16_t> mm(f.depth.width(), f.depth.height());
  for (int y = 0; y < mm.height(); ++y)
    for (int x = 0; x < mm.width(); ++x) mm(x, y) = static_cast<uint16_t>(f.depth(x, y) * 1000.0f + 0.5f);
  check(write_png(scratch("depth.png"), mm.view()), "depth.png");
  check(write_png(scratch("labels.png"), f.labels.view()), "labels.png");
  check(write_png(scratch("color.png"), f.color.view()), "color.png");
  const std::string depth = fuzz::read_file(scratch("depth.png")), labels = fuzz::read_file(scratch("labels.png")),
                    color = fuzz::read_file(scratch("color.png"));
  // fuzz_png: byte 0 = reader (0..2 memory u16 u8 rgb, 3..5 files u16 u8 colour).
  seed("png", "depth_u16_memory.png", depth, byte(0));
  seed("png", "labels_u8_memory.png", labels, byte(1));
  seed("png", "color_rgb_memory.png", color, byte(2));
  seed("png", "depth_u16_file.png", depth, byte(3));
  seed("png", "labels_u8_file.png", labels, byte(4));
  seed("png", "color_file.png", color, byte(5));
  seed("png", "gray16_as_color_file.png", depth, byte(5));  // 16-bit gray reduced to RGB
  seed("png", "gray8_as_color_memory.png", labels, byte(2));

  // fuzz_jpeg: byte 0 even = decode_jpeg, odd = read_color_image.
  std::string jpeg;
  check(encode_jpeg(f.color.view(), 90, jpeg), "jpeg");
  seed("jpeg", "q90_memory.jpg", jpeg, byte(0));
  seed("jpeg", "q90_file.jpg", jpeg, byte(1));
  check(encode_jpeg(f.color.view(), 20, jpeg), "jpeg");
  seed("jpeg", "q20_memory.jpg", jpeg, byte(0));
  check(encode_jpeg(r.frames[1].color.view(), 100, jpeg), "jpeg");
  seed("jpeg", "q100_file.jpg", jpeg, byte(1));

  // fuzz_ppm: no writer of ours makes PPM (the reader takes other tools' files), so the seeds are
  // the frame's colour in the three forms the reader handles: maxval 255 (read whole), another
  // 8-bit maxval (scaled), 16-bit samples; with a comment in the header.
  const int w = f.color.width(), h = f.color.height();
  const auto ppm = [&](int maxval, const char* comment) {
    std::string s = "P6\n" + std::string(comment) + std::to_string(w) + " " + std::to_string(h) + "\n" +
                    std::to_string(maxval) + "\n";
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const Rgb8 p = f.color(x, y);
        for (const uint8_t c : {p.r, p.g, p.b}) {
          const unsigned v = static_cast<unsigned>(c) * static_cast<unsigned>(maxval) / 255u;
          if (maxval > 255) s += byte(int(v >> 8));
          s += byte(int(v & 0xFF));
        }
      }
    return s;
  };
  seed("ppm", "maxval255.ppm", ppm(255, ""));
  seed("ppm", "maxval100_comment.ppm", ppm(100, "# made by fuzz_corpus\n"));
  seed("ppm", "maxval65535.ppm", ppm(65535, ""));
}

// ---- Recordings (fuzz_klg, fuzz_mcap, fuzz_lists, fuzz_uri) ----

void recording_seeds(const fuzz::Recording& r) {
  // fuzz_klg: bytes 0 and 1 = width - 1, height - 1 (1..32 each), then the .klg. The JPEG seed's
  // frames are 32x24: the writer stores raw colour when a JPEG would not be smaller, which at 16x12
  // (576 bytes raw, the JPEG's tables alone about as much) it never is.
  const std::string size = byte(r.intrinsics.width - 1) + byte(r.intrinsics.height - 1);
  const fuzz::Recording r32 = fuzz::synthetic_recording(2, 32, 24);
  const auto has_jpeg = [](const std::string& bytes) {
    if (bytes.find("\xFF\xD8\xFF") != std::string::npos) return bytes;
    std::fprintf(stderr, "fuzz_corpus: a .klg seed meant to hold JPEG colour holds none\n");
    std::exit(1);
  };
  fuzz::write_klg(scratch("zlib_jpeg.klg"), r32, KlgWriteOptions{true, 50});
  seed("klg", "zlib_depth_jpeg_color.klg", has_jpeg(fuzz::read_file(scratch("zlib_jpeg.klg"))), byte(31) + byte(23));
  fuzz::write_klg(scratch("raw_jpeg.klg"), r32, KlgWriteOptions{false, 90});
  seed("klg", "raw_depth_jpeg_color.klg", has_jpeg(fuzz::read_file(scratch("raw_jpeg.klg"))), byte(31) + byte(23));
  fuzz::write_klg(scratch("zlib_raw.klg"), r, KlgWriteOptions{true, 0});
  seed("klg", "zlib_depth_raw_color.klg", fuzz::read_file(scratch("zlib_raw.klg")), size);
  fuzz::write_klg(scratch("raw.klg"), r, KlgWriteOptions{false, 0});
  const std::string raw = fuzz::read_file(scratch("raw.klg"));
  seed("klg", "raw_depth_raw_color.klg", raw, size);
  fuzz::write_klg(scratch("nocolor.klg"), r, KlgWriteOptions{true, 90}, /*color=*/false);
  seed("klg", "zlib_depth_no_color.klg", fuzz::read_file(scratch("nocolor.klg")), size);
  // A recording cut while written (a kill): the last frame is partial.
  seed("klg", "cut_while_written.klg", raw.substr(0, raw.size() - 100), size);

  // fuzz_mcap: field logs as `convert --to mcap:` and `log` write them.
  McapLogOptions o;
  fuzz::write_mcap(scratch("png_jpeg.mcap"), r, o);
  seed("mcap", "png_depth_jpeg_color.mcap", fuzz::read_file(scratch("png_jpeg.mcap")));
  o.depth = "raw";
  o.color = "raw";
  fuzz::write_mcap(scratch("raw.mcap"), r, o);
  seed("mcap", "raw_depth_raw_color.mcap", fuzz::read_file(scratch("raw.mcap")));
  o.depth = "png";
  o.color = "png";
  fuzz::write_mcap(scratch("png_png.mcap"), r, o);
  const std::string png_png = fuzz::read_file(scratch("png_png.mcap"));
  seed("mcap", "png_depth_png_color.mcap", png_png);
  o.color = "none";
  fuzz::write_mcap(scratch("nocolor.mcap"), r, o);
  seed("mcap", "png_depth_no_color.mcap", fuzz::read_file(scratch("nocolor.mcap")));
  seed("mcap", "cut_while_written.mcap", png_png.substr(0, png_png.size() * 2 / 3));

  // fuzz_lists: byte 0 = parser (0 TUM list, 1 groundtruth, 2 TUM intrinsics, 3 7-Scenes pose,
  // 4 7-Scenes intrinsics, 5 source URI).
  const std::string tum = scratch("tum");
  fuzz::write_tum(tum, r);
  seed("lists", "tum_rgb.txt", fuzz::read_file(tum + "/rgb.txt"), byte(0));
  seed("lists", "tum_depth.txt", fuzz::read_file(tum + "/depth.txt"), byte(0));
  seed("lists", "tum_groundtruth.txt", fuzz::read_file(tum + "/groundtruth.txt"), byte(1));
  seed("lists", "tum_intrinsics.txt", fuzz::read_file(tum + "/intrinsics.txt"), byte(2));
  const std::string seven = scratch("7scenes");
  fuzz::write_7scenes(seven, r);
  seed("lists", "7scenes_pose.txt", fuzz::read_file(seven + "/frame-000001.pose.txt"), byte(3));
  const Intrinsics& k = r.intrinsics;
  char kt[160];
  std::snprintf(kt, sizeof kt, "%.9g 0 %.9g\n0 %.9g %.9g\n0 0 1\n", double(k.fx), double(k.cx), double(k.fy), double(k.cy));
  seed("lists", "7scenes_camera_intrinsics.txt", kt, byte(4));
  seed("lists", "uri.txt", "klg:rec.klg?size=16x12&fx=20&fy=20&cx=7.5&cy=5.5", byte(5));
  check(write_klg_side_file(scratch("side.klg"), r.intrinsics), "side file");
  seed("lists", "klg_side_file.txt", fuzz::read_file(klg_side_file(scratch("side.klg"))), byte(6));

  // fuzz_trajectory: "<ground truth>\0<estimate>": the TUM writer's ground truth, and the run's own
  // trajectory writer with a lost frame marked.
  const std::string est = scratch("trajectory.txt");
  TumTrajectoryWriter tw;
  check(tw.open(est), "trajectory.txt");
  for (std::size_t i = 0; i < r.frames.size(); ++i) {
    if (i == 1) check(tw.write_comment(("lost " + std::to_string(r.frames[i].timestamp) + " too few inliers").c_str()), "lost");
    SE3 T = r.frames[i].T_wc;
    T = SE3(T.rotation(), T.translation() + Eigen::Vector3d(0.002 * double(i), 0, -0.001));
    check(tw.write(r.frames[i].timestamp, T), "trajectory.txt");
  }
  check(tw.close(), "trajectory.txt");
  const std::string gt_text = fuzz::read_file(tum + "/groundtruth.txt"), est_text = fuzz::read_file(est);
  seed("trajectory", "groundtruth_and_estimate.txt", gt_text + std::string(1, '\0') + est_text);
  seed("trajectory", "estimate_alone.txt", est_text);
  // A trajectory cut while written (no newline at the end of the last line).
  seed("trajectory", "estimate_cut.txt", est_text.substr(0, est_text.size() - 7));
}

// ---- Maps (fuzz_ply) ----

void ply_seeds() {
  // 24 surfels on two walls of a corner, every column set, as map.ply has them.
  SurfelCloud c;
  for (int i = 0; i < 24; ++i) {
    const bool wall = i < 12;
    const float u = 0.1f * float(i % 4), v = 0.1f * float((i / 4) % 3);
    c.x.push_back(wall ? u : 0.0f);
    c.y.push_back(v);
    c.z.push_back(wall ? 1.0f : 1.0f - u);
    c.nx.push_back(wall ? 0.0f : 1.0f);
    c.ny.push_back(0.0f);
    c.nz.push_back(wall ? -1.0f : 0.0f);
    c.red.push_back(static_cast<uint8_t>(40 + 8 * i));
    c.green.push_back(static_cast<uint8_t>(200 - 5 * i));
    c.blue.push_back(static_cast<uint8_t>(90));
    c.radius.push_back(0.02f + 0.001f * float(i));
    c.confidence.push_back(1.0f + float(i));
    c.class_id.push_back(static_cast<uint8_t>(i % 14));
    c.class_prob.push_back(0.5f + 0.02f * float(i));
  }
  check(write_surfel_ply(scratch("map.ply"), c.view(), "fuzz_corpus: a corner"), "map.ply");
  seed("ply", "map_with_classes.ply", fuzz::read_file(scratch("map.ply")));
  c.has_classes = false;
  check(write_surfel_ply(scratch("map_nolabels.ply"), c.view()), "map.ply");
  seed("ply", "map_without_classes.ply", fuzz::read_file(scratch("map_nolabels.ply")));
}

// ---- URIs (fuzz_uri) ----

void uri_seeds() {
  const char* const uris[][2] = {
      {"synthetic_all_keys", "synthetic:bedroom?seed=7&trajectory=robot&frames=3&size=16x12&noise=0&camera=kinect&layout=island&depth_bias=0.02"},
      {"synthetic_random", "synthetic:random?seed=4294967295&trajectory=inspect&frames=2&size=8x8&noise=1&camera=ideal&layout=walls&depth_bias=-0.2"},
      {"synthetic_default", "synthetic:"},
      {"klg_all_keys", "klg:rec.klg?size=16x12&fx=20&fy=21&cx=7.5&cy=5.5"},
      {"klg_cut_blank", "klg:rec.klg?cut=0-0&blank=1+2"},
      {"tum_intrinsics", "tum:folder?fx=20.5&fy=20.5&cx=7.5&cy=5.5&blank=1+1"},
      {"7scenes_intrinsics", "7scenes:seq-01?fx=585&fy=585&cx=320&cy=240&cut=1-1"},
      {"mcap_topics", "mcap:log.mcap?depth=/camera/depth&color=/camera/color&cut=0-0"},
      {"openni2_all_keys", "openni2:Dummy?size=640x480&fps=30&timeout_ms=2000&registration=1&fx=525&fy=525&cx=319.5&cy=239.5"},
      {"openni2_oni", "openni2:rec.oni?registration=0"},
      {"v4l2_all_keys", "v4l2:/dev/video0?format=z16&size=640x480&fps=30&timeout_ms=500&depth_scale=0.001&fx=500&fy=500&cx=320&cy=240"},
  };
  for (const auto& u : uris) seed("uri", std::string(u[0]) + ".txt", u[1]);
}

// ---- Configuration (fuzz_config) and command line (fuzz_args) ----

void config_seeds() {
  using pipeline::RunConfig;
  // Every section and key, as `plan --help` prints it (comments, units, ranges).
  seed("config", "describe_defaults.yaml", RunConfig().describe());
  // A value other than the default in every section.
  RunConfig c;
  const char* const changes[][2] = {
      {"source", "klg:/data/rec.klg?size=320x240"}, {"out", "/var/lib/edgefusion/{time}"},
      {"mapping.surfel_capacity", "200000"},       {"mapping.icp_weight", "5"},
      {"labels.every", "5"},                        {"labels.out", "labels"},
      {"labels.out_every", "3"},                    {"crf.every", "100"},
      {"crf.iterations", "3"},                      {"pipeline.threads", "3"},
      {"pipeline.pinning", "auto"},                 {"memory.budget_mb", "512"},
      {"output.checkpoint_seconds", "10"},          {"log.file", "field.mcap"},
      {"log.color", "png"},                         {"gpio.led_chip", "gpiochip0"},
      {"gpio.led_line", "17"},                      {"gpio.optional", "true"},
  };
  for (const auto& kv : changes) check(app::apply_config_value(kv[0], kv[1], "fuzz_corpus", c), kv[0]);
  seed("config", "describe_changed.yaml", c.describe());
  // Flat names, flow-style sections, a URI ending in ':' on a plain line (quoted by the reader).
  seed("config", "flat_and_flow.yaml",
       "source: synthetic:\nresolution: 160x120\nframes: 30\nsurfel_capacity: 100000\nlabel_every: 2\n"
       "crf_iterations: 2\nlabels: true\ncrf: {every: 50, final: true}\noutput: {overwrite: true, sync_seconds: 0}\n"
       "pipeline:\n  threads: 1\n  deterministic: true\n");
}

// A command line's argument for a value (as the user types it, not YAML).
std::string arg_text(const opt::Value& v) {
  switch (v.kind) {
    case opt::Value::kText: return v.text.empty() ? "x" : v.text;
    case opt::Value::kSize: return std::to_string(v.size.width) + "x" + std::to_string(v.size.height);
    default: return opt::yaml_text(v);
  }
}

void args_seeds() {
  const auto& syntaxes = app::command_syntaxes();
  const auto index_of = [&](const char* words) {
    for (std::size_t i = 0; i < syntaxes.size(); ++i)
      if (std::string(syntaxes[i].words) == words) return static_cast<int>(i);
    std::fprintf(stderr, "fuzz_corpus: no command '%s'\n", words);
    std::exit(1);
  };
  const auto line = [](const std::vector<std::string>& args) {
    std::string s;
    for (std::size_t i = 0; i < args.size(); ++i) s += (i ? std::string(1, '\0') : std::string()) + args[i];
    return s;
  };
  // run and plan: every configuration flag with its default value (a bool's flag alone).
  std::vector<std::string> all;
  const pipeline::RunConfig defaults;
  for (const pipeline::ConfigKey& k : pipeline::config_keys()) {
    if (k.flag.empty()) continue;
    all.push_back(k.flag);
    if (k.kind != opt::Value::kBool) all.push_back(k.path == "out" ? "/tmp/run" : arg_text(k.get(defaults)));
  }
  seed("args", "run_every_flag.txt", line(all), byte(index_of("run")));
  seed("args", "plan_keys.txt", line({"--keys"}), byte(index_of("plan")));
  seed("args", "run_typical.txt",
       line({"--source", "klg:rec.klg", "--resolution=160x120", "--frames", "30", "--out", "out", "--threads", "1",
             "--crf-every", "100", "--labels-out", "labels", "--labels-out-every", "5"}),
       byte(index_of("run")));
  seed("args", "eval_ate.txt", line({"gt.txt", "est.txt", "--max-dt", "0.02"}), byte(index_of("eval ate")));
  seed("args", "eval_rpe.txt", line({"gt.txt", "est.txt", "--delta-frames", "30", "--max-dt=0.05"}), byte(index_of("eval rpe")));
  seed("args", "eval_labels.txt", line({"pred", "truth", "--depth", "depth", "--every", "10"}), byte(index_of("eval labels")));
  seed("args", "convert.txt",
       line({"--source", "synthetic:?frames=2", "--to", "klg:x.klg", "--frames", "2", "--resolution", "64x48",
             "--jpeg-quality", "80", "--raw-depth", "--quiet"}),
       byte(index_of("convert")));
  seed("args", "log.txt",
       line({"--source", "synthetic:", "--out", "x.mcap", "--frames", "9", "--realtime", "--log-depth", "raw", "--log-color",
             "png", "--color-every", "3", "--jpeg-quality", "70", "--chunk-seconds", "0.5", "--overwrite", "--quiet"}),
       byte(index_of("log")));
  seed("args", "segment.txt",
       line({"--model", "m.efm", "--source", "synthetic:", "--out", "seg", "--frames", "4", "--every", "2", "--probabilities",
             "--isa", "sse41", "--threads", "2", "--quiet"}),
       byte(index_of("segment")));
  seed("args", "model_info.txt", line({"m.efm", "--isa", "scalar"}), byte(index_of("model info")));
  seed("args", "model_import.txt",
       line({"--tflite", "m.tflite", "--calibration", "synthetic:", "--out", "m.efm", "--frames", "8", "--input", "257x257",
             "--class-map", "{}", "--labels", "l.txt", "--golden-dir", "g"}),
       byte(index_of("model import")));
  seed("args", "export.txt", line({"run", "--out", "map.ply"}), byte(index_of("export")));
  seed("args", "view.txt",
       line({"map.ply", "--out", "v.png", "--pose", "0 0 0 0 0 0 1", "--trajectory", "t.txt", "--size", "320x240"}),
       byte(index_of("view")));
  seed("args", "help.txt", line({"--help"}), byte(index_of("convert")));
}

// ---- Checkpoints (fuzz_snapshot) ----

void checkpoint_seeds() {
  // The SLAM of fuzz_snapshot, with a pool of 48 surfels: the seed stays a few kB (the pool's
  // columns are most of a checkpoint), and it holds a full pool (its refusals counted).
  slam::SurfelSlamOptions options = fuzz::checkpoint_slam_options();
  options.pool.capacity = 48;
  const Intrinsics k = fuzz::checkpoint_working_intrinsics();
  const fuzz::Recording r = fuzz::synthetic_recording(3, k.width, k.height);
  auto slam = slam::SurfelSlam::create(k, options);
  if (!slam.ok()) check(slam.error(), "SurfelSlam");
  StageStats stats;
  const int frames = stats.add_counter("frames");
  stats.add_counter("surfels_created");
  std::string names;
  const fs::path dir = g_scratch / "run";
  fs::create_directories(dir);
  for (std::size_t i = 0; i < r.frames.size(); ++i) {
    slam::SlamFrameResult result;
    check(slam->process(r.frames[i], &result), "SurfelSlam::process");
    stats.set_counter(frames, i + 1);
    if (i == 0 || i + 1 == r.frames.size()) {
      pipeline::CheckpointMeta meta;
      meta.frames = slam->frames();
      meta.last_timestamp = r.frames[i].timestamp;
      meta.trajectory_bytes = 60 * static_cast<int64_t>(i + 1);
      meta.width = k.width;
      meta.height = k.height;
      meta.capacity = options.pool.capacity;
      meta.seconds = 1.5 * double(i + 1);  // fixed: the seed is the same bytes every time
      meta.labels = i == 0;
      check(pipeline::write_checkpoint(dir.string(), meta, *slam, stats, names), "checkpoint");
      seed("snapshot", "checkpoint_after_frame_" + std::to_string(i + 1) + ".efs",
           fuzz::read_file((dir / pipeline::kCheckpointFile).string()));
    }
  }
  // A plain snapshot with sections of other sizes (the container alone; no checkpoint in it).
  SnapshotWriter w;
  const std::string path = scratch("other.efs");
  check(w.open(path), "snapshot");
  const char odd[3] = {'a', 'b', 'c'};
  check(w.section("ODD3", odd, sizeof odd), "snapshot");
  check(w.section("NONE", static_cast<const void*>(odd), 0), "snapshot");
  check(w.commit(), "snapshot");
  seed("snapshot", "container_only.efs", fuzz::read_file(path));
}

// ---- Models (fuzz_model) ----

// One layer between the input and a softmax: every layer type with its own parameters, each model
// a few hundred bytes, all far within fuzz_model's work limit.
nn::ModelDesc one_layer(const std::string& name, nn::LayerDesc l, nn::TensorDesc out, uint32_t seed) {
  std::mt19937 rng(seed);
  nn::ModelDesc d;
  d.name = name;
  d.input_mean = {128.0f, 128.0f, 128.0f, 1.5f};
  d.input_scale = {1.0f / 64, 1.0f / 64, 1.0f / 64, 1.0f};
  const nn::TensorDesc in = test::tensor(6, 6, 4, 0.03f, -3);
  if (l.type == nn::LayerType::kClamp || l.type == nn::LayerType::kMaxPool || l.type == nn::LayerType::kUpsample ||
      l.type == nn::LayerType::kResizeBilinear) {
    out.scale = in.scale;  // these keep the input's quantisation
    out.zero_point = in.zero_point;
  }
  d.tensors = {in, out, test::float_tensor(out.h, out.w, out.c)};
  for (uint32_t c = 0; c < out.c; ++c) d.class_names.push_back("class" + std::to_string(c));
  d.input_tensor = 0;
  d.output_tensor = 2;
  const uint32_t cin = in.c;
  if (l.type == nn::LayerType::kConv2d) test::fill_weights(l, out.c, l.kernel_h * l.kernel_w * cin, rng);
  if (l.type == nn::LayerType::kDepthwiseConv2d) test::fill_weights(l, out.c, l.kernel_h * l.kernel_w, rng);
  if (l.type == nn::LayerType::kPointwiseConv2d) test::fill_weights(l, out.c, cin, rng);
  d.layers = {l, test::layer(nn::LayerType::kSoftmax, {1}, 2)};
  return d;
}

void model_seeds() {
  using nn::LayerType;
  std::vector<nn::ModelDesc> models;
  models.push_back(test::tiny_net(1));  // every type but resize_bilinear, in one graph
  nn::ModelDesc mapped = test::tiny_net(2);  // version 2: a class map (CMAP)
  mapped.name = "tiny_class_map";
  mapped.class_map = {0, 1, 1, 2, 0};
  mapped.target_class_names = {"unknown", "structure", "furniture"};
  models.push_back(mapped);

  const auto L = [](LayerType t) { return test::layer(t, {0}, 1); };
  {
    auto l = L(LayerType::kConv2d);  // 3x3, stride 2, uneven padding, ReLU range
    l.kernel_h = l.kernel_w = 3;
    l.stride_h = l.stride_w = 2;
    l.pad_top = l.pad_left = 1;
    l.act = nn::Activation::kRelu;
    l.out_min = 0;
    models.push_back(one_layer("conv3x3_s2", l, test::tensor(3, 3, 5, 0.05f, 0), 11));
  }
  {
    auto l = L(LayerType::kConv2d);  // 3x3, dilation 2, padding 2
    l.kernel_h = l.kernel_w = 3;
    l.dilation_h = l.dilation_w = 2;
    l.pad_top = l.pad_left = l.pad_bottom = l.pad_right = 2;
    models.push_back(one_layer("conv3x3_d2", l, test::tensor(6, 6, 3, 0.05f, 4), 12));
  }
  {
    auto l = L(LayerType::kConv2d);  // 1x5, stride 1x2, no padding
    l.kernel_w = 5;
    l.stride_w = 2;
    models.push_back(one_layer("conv1x5", l, test::tensor(6, 1, 2, 0.04f, -1), 13));
  }
  {
    auto l = L(LayerType::kDepthwiseConv2d);
    l.kernel_h = l.kernel_w = 3;
    l.pad_top = l.pad_left = l.pad_bottom = l.pad_right = 1;
    models.push_back(one_layer("depthwise3x3", l, test::tensor(6, 6, 4, 0.04f, 2), 14));
  }
  models.push_back(one_layer("pointwise", L(LayerType::kPointwiseConv2d), test::tensor(6, 6, 3, 0.06f, -7), 15));
  {
    auto l = test::layer(LayerType::kAdd, {0, 0}, 1);
    models.push_back(one_layer("add", l, test::tensor(6, 6, 4, 0.07f, 1), 16));
  }
  {
    auto l = test::layer(LayerType::kConcat, {0, 0, 0}, 1);
    models.push_back(one_layer("concat3", l, test::tensor(6, 6, 12, 0.05f, -2), 17));
  }
  {
    auto l = L(LayerType::kClamp);
    l.act = nn::Activation::kRelu6;
    l.out_min = -3;
    l.out_max = 120;
    models.push_back(one_layer("clamp_relu6", l, test::tensor(6, 6, 4, 0, 0), 18));
  }
  {
    auto l = L(LayerType::kMaxPool);
    l.kernel_h = l.kernel_w = 3;
    l.stride_h = l.stride_w = 2;
    l.pad_top = l.pad_left = l.pad_bottom = l.pad_right = 1;
    models.push_back(one_layer("maxpool3x3_s2", l, test::tensor(3, 3, 4, 0, 0), 19));
  }
  {
    auto l = L(LayerType::kAvgPool);
    l.kernel_h = l.kernel_w = 2;
    l.stride_h = l.stride_w = 2;
    models.push_back(one_layer("avgpool2x2", l, test::tensor(3, 3, 4, 0.02f, 5), 20));
  }
  {
    auto l = L(LayerType::kAvgPool);  // global: the window is the whole 6x6 input
    l.kernel_h = l.kernel_w = 6;
    models.push_back(one_layer("avgpool_global", l, test::tensor(1, 1, 4, 0.02f, 0), 21));
  }
  {
    auto l = L(LayerType::kUpsample);
    l.factor = 3;
    models.push_back(one_layer("upsample_nearest_x3", l, test::tensor(18, 18, 4, 0, 0), 22));
  }
  {
    auto l = L(LayerType::kUpsample);
    l.factor = 2;
    l.mode = nn::UpsampleMode::kBilinear;
    models.push_back(one_layer("upsample_bilinear_x2", l, test::tensor(12, 12, 4, 0, 0), 23));
  }
  models.push_back(one_layer("resize_bilinear_5x7", L(LayerType::kResizeBilinear), test::tensor(5, 7, 4, 0, 0), 24));
  {
    nn::ModelDesc d = one_layer("softmax_only", L(LayerType::kClamp), test::tensor(6, 6, 4, 0, 0), 25);
    d.layers = {test::layer(LayerType::kSoftmax, {0}, 2)};
    d.tensors[2] = test::float_tensor(6, 6, 4);
    d.tensors.erase(d.tensors.begin() + 1);
    d.output_tensor = 1;
    d.layers[0].output = 1;
    models.push_back(d);
  }
  for (const nn::ModelDesc& d : models) {
    auto bytes = nn::serialize_model(d);
    if (!bytes.ok()) check(bytes.error(), d.name.c_str());
    // Each must load and run as fuzz_model runs it: a seed that stops early would not reach the executor.
    auto model = nn::load_model_memory(bytes->data(), bytes->size(), d.name);
    if (!model.ok()) check(model.error(), d.name.c_str());
    auto ex = nn::Executor::create(*model);
    if (!ex.ok()) check(ex.error(), d.name.c_str());
    std::vector<float> in((*ex)->input_floats(), 100.0f), out((*ex)->output_floats());
    check((*ex)->run(in.data(), in.size(), out.data(), out.size()), d.name.c_str());
    seed("model", d.name + ".efm", *bytes);
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: fuzz_corpus OUT_DIR   (writes OUT_DIR/<target>/<seed>)\n");
    return 2;
  }
  g_out = argv[1];
  g_scratch = g_out / ".scratch";
  fs::remove_all(g_scratch);
  fs::create_directories(g_scratch);
  const fuzz::Recording r = fuzz::synthetic_recording(2, 16, 12);
  image_seeds(fuzz::synthetic_recording(2, 8, 8));
  recording_seeds(r);
  uri_seeds();
  ply_seeds();
  config_seeds();
  args_seeds();
  checkpoint_seeds();
  model_seeds();
  fs::remove_all(g_scratch);
  std::printf("fuzz_corpus: seeds written under %s\n", g_out.c_str());
  return 0;
}
