// Golden hashes of the synthetic generator: "deterministic for a given seed and version", checked.
//
// The same constants must hold natively on x86-64 and on ARM64 (CI runs this binary under
// qemu-aarch64 with QEMU_CPU=cortex-a53 and QEMU_CPU=max): a mismatch on one ISA only means a
// cross-architecture divergence crept into src/synth (libm trigonometry, fused multiply-add,
// unspecified evaluation order, an out-of-range float to integer conversion, ...).
//
// The constants change ONLY when the generator's version changes on purpose (a new room recipe,
// texture, noise model or trajectory shape): then record the new values printed by the failing
// test, on x86-64 and under qemu-aarch64 both, and say so in the commit message.
#include <cinttypes>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "synth/det_math.h"
#include "synth/room_builder.h"
#include "synth/synthetic_source.h"
#include "test_synth_support.h"

namespace ef {
namespace {

// 64-bit FNV-1a over bytes; multi-byte values are fed least significant byte first, so the hash
// does not depend on the machine's byte order.
class Fnv1a {
 public:
  void byte(uint8_t b) {
    h_ ^= b;
    h_ *= 0x100000001b3ULL;
  }
  void u32(uint32_t v) {
    for (int i = 0; i < 4; ++i) byte(static_cast<uint8_t>(v >> (8 * i)));
  }
  void u64(uint64_t v) {
    for (int i = 0; i < 8; ++i) byte(static_cast<uint8_t>(v >> (8 * i)));
  }
  void f32(float f) {
    uint32_t bits;
    std::memcpy(&bits, &f, sizeof(bits));
    u32(bits);
  }
  void f64(double d) {
    uint64_t bits;
    std::memcpy(&bits, &d, sizeof(bits));
    u64(bits);
  }
  // A double rounded to 1e-6 (poses: robust to nothing, but readable when printed).
  void micro(double d) { u64(static_cast<uint64_t>(std::llround(d * 1e6))); }
  uint64_t value() const { return h_; }

 private:
  uint64_t h_ = 0xcbf29ce484222325ULL;
};

std::string hex(uint64_t v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "0x%016" PRIx64 "ULL", v);
  return buf;
}

void hash_frame(const Frame& f, Fnv1a& colour, Fnv1a& depth, Fnv1a& labels) {
  for (int y = 0; y < f.color.height(); ++y)
    for (int x = 0; x < f.color.width(); ++x) {
      const Rgb8 c = f.color.view()(x, y);
      colour.byte(c.r);
      colour.byte(c.g);
      colour.byte(c.b);
    }
  for (int y = 0; y < f.depth.height(); ++y)
    for (int x = 0; x < f.depth.width(); ++x) depth.f32(f.depth.view()(x, y));
  for (int y = 0; y < f.labels.height(); ++y)
    for (int x = 0; x < f.labels.width(); ++x) labels.byte(f.labels.view()(x, y));
}

void hash_scene(const synth::Scene& s, Fnv1a& h) {
  for (int i = 0; i < 3; ++i) h.f32(s.size[i]);
  for (const synth::Material& m : s.face_material) {
    for (int i = 0; i < 3; ++i) h.f32(m.base[i]);
    h.f32(m.scale);
    h.u32(m.seed);
  }
  for (const synth::Primitive& p : s.primitives) {
    h.byte(static_cast<uint8_t>(p.shape));
    h.byte(p.label);
    for (int i = 0; i < 3; ++i) {
      h.f32(p.center[i]);
      h.f32(p.half[i]);
      h.f32(p.material.base[i]);
      h.f32(p.material.accent[i]);
    }
    h.f32(p.yaw);
    h.f32(p.cos_yaw);
    h.f32(p.sin_yaw);
    h.byte(static_cast<uint8_t>(p.material.texture));
    h.f32(p.material.scale);
    h.f32(p.material.emission);
    h.u32(p.material.seed);
  }
  for (const synth::Light& l : s.lights) {
    for (int i = 0; i < 3; ++i) {
      h.f32(l.position[i]);
      h.f32(l.color[i]);
    }
  }
  for (int i = 0; i < 3; ++i) h.f32(s.ambient[i]);
}

struct Golden {
  const char* uri;
  int frames[2];      // the two frames rendered
  uint64_t scene;     // room layout, materials, lights (exact bits)
  uint64_t poses;     // every pose of the sequence, rounded to 1e-6
  uint64_t colour;    // colour bytes of the two frames
  uint64_t depth;     // depth bits of the two frames (after noise)
  uint64_t labels;    // label bytes of the two frames
};

// Recorded on x86-64 (GCC, Release and ASan+UBSan) and qemu-aarch64 (cortex-a53 and max): the same
// values everywhere. Change them only with a deliberate change of the generator's version.
constexpr Golden kGolden[] = {
    {"synthetic:?frames=60&size=160x120", {0, 59},
     0x9ce4655bad8f91ddULL, 0x7dc7506524026af8ULL, 0x8c20f41def0c3051ULL, 0x22aa5f249c6d4423ULL, 0x5ea86aa561f9e06fULL},
    {"synthetic:random?seed=7&trajectory=robot&frames=60&size=160x120", {3, 57},
     0xdf51330a3a58a566ULL, 0x083f01bb54f01bceULL, 0x6f2c52d8342dbe00ULL, 0x005343ccd8980343ULL, 0xbbea7ea169685ef6ULL},
    // The Kinect-like colour camera (camera_model.h): blur over interpolated poses, exposure, noise.
    {"synthetic:random?seed=7&frames=60&size=160x120&camera=kinect", {3, 57},
     0xdf51330a3a58a566ULL, 0x43561c90f6149951ULL, 0x8c3c6d2ed16da5b3ULL, 0x3134d1e1b47e8438ULL, 0x2b2e77d17f61e6e1ULL},
    // The inspecting scan: the loop's path, the gaze turning to the near wall and back.
    {"synthetic:random?seed=7&frames=60&size=160x120&trajectory=inspect", {3, 57},
     0xdf51330a3a58a566ULL, 0x9a61c4a5f42d1df2ULL, 0x1ae7ce47119f7780ULL, 0x8df38177f2e25e99ULL, 0x3ea877c9635c4f6fULL},
};

TEST(SynthGolden, FramesAndPosesMatchRecordedHashes) {
  for (const Golden& g : kGolden) {
    auto src = test::open_synth(g.uri);
    ASSERT_TRUE(src) << g.uri;
    Fnv1a scene;
    hash_scene(src->scene(), scene);
    Fnv1a poses;
    for (const SE3& T : src->poses()) {
      const Eigen::Quaterniond& q = T.rotation();
      // One sign convention for the quaternion (q and -q are the same rotation).
      const double sign = q.w() < 0 ? -1.0 : 1.0;
      for (int i = 0; i < 4; ++i) poses.micro(sign * q.coeffs()[i] + 0.0);
      for (int i = 0; i < 3; ++i) poses.micro(T.translation()[i]);
    }
    Fnv1a colour, depth, labels;
    for (int index : g.frames) {
      Frame f;
      ASSERT_TRUE(src->render(index, f).ok()) << g.uri;
      hash_frame(f, colour, depth, labels);
    }
    EXPECT_EQ(scene.value(), g.scene) << g.uri << ": scene hash " << hex(scene.value());
    EXPECT_EQ(poses.value(), g.poses) << g.uri << ": poses hash " << hex(poses.value());
    EXPECT_EQ(colour.value(), g.colour) << g.uri << ": colour hash " << hex(colour.value());
    EXPECT_EQ(depth.value(), g.depth) << g.uri << ": depth hash " << hex(depth.value());
    EXPECT_EQ(labels.value(), g.labels) << g.uri << ": labels hash " << hex(labels.value());
  }
}

// The deterministic trigonometry itself, bit for bit: any ISA or compiler difference in it shows
// here first, before it is amplified into rooms and poses.
TEST(SynthGolden, DeterministicTrigonometryMatchesRecordedHash) {
  Fnv1a h;
  uint32_t state = 12345;
  for (int i = 0; i < 20000; ++i) {
    state = state * 1664525u + 1013904223u;
    const double x = (static_cast<double>(state) / 4294967296.0 - 0.5) * 200.0;  // [-100, 100)
    double s, c;
    synth::det_sincos(x, s, c);
    h.f64(s);
    h.f64(c);
    // (No a * b + c in this file: tests are compiled with FMA contraction, src/synth is not.)
    h.f64(synth::det_atan2(s, c - 0.5));
  }
  constexpr uint64_t kTrigHash = 0x0a7b5747c7173d0bULL;
  EXPECT_EQ(h.value(), kTrigHash) << "trigonometry hash " << hex(h.value());
}

TEST(SynthGolden, DeterministicTrigonometryIsAccurate) {
  double worst_sin = 0, worst_cos = 0, worst_atan = 0;
  for (int i = -200000; i <= 200000; ++i) {
    const double x = i * 1.37e-3;  // [-274, 274] radians
    double s, c;
    synth::det_sincos(x, s, c);
    worst_sin = std::max(worst_sin, std::fabs(s - std::sin(x)));
    worst_cos = std::max(worst_cos, std::fabs(c - std::cos(x)));
    EXPECT_EQ(synth::det_sin(x), s);
    EXPECT_EQ(synth::det_cos(x), c);
    const double y = std::sin(x * 0.77) * 3.0, z = std::cos(x * 1.3) - 0.2;
    worst_atan = std::max(worst_atan, std::fabs(synth::det_atan2(y, z) - std::atan2(y, z)));
  }
  EXPECT_LT(worst_sin, 1e-14);
  EXPECT_LT(worst_cos, 1e-14);
  EXPECT_LT(worst_atan, 1e-15);
  EXPECT_EQ(synth::det_atan2(0.0, 0.0), 0.0);
  EXPECT_EQ(synth::det_atan2(0.0, -1.0), 3.141592653589793);
  EXPECT_EQ(synth::det_atan2(1.0, 0.0), 1.5707963267948966);
  EXPECT_EQ(synth::det_atan2(-1.0, 0.0), -1.5707963267948966);
  EXPECT_EQ(synth::det_sin(0.0), 0.0);
  EXPECT_EQ(synth::det_cos(0.0), 1.0);
  EXPECT_TRUE(std::isnan(synth::det_sin(1e7)));
}

}  // namespace
}  // namespace ef
