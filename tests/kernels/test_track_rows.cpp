// track_rows: every variant the CPU can run writes the same bits as the scalar reference (runs of
// every length around the vector widths, each term on its own and both, with and without the depth
// gate, poses that push points behind the camera and out of the image, padded strides, unaligned
// pointers, poisoned buffers that catch writes out of range); the reference follows the formulas of
// kernels/track_rows.h on hand-made pixels (rows, gates, Huber weight, zero rows); and a fixed input
// gives the same bits on every architecture.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "kernel_test_util.h"
#include "kernels/track_rows.h"
#include "kernels/track_rows_variants.h"

// The inputs of the cross-architecture test must not depend on the compiler fusing a * b + c (GCC
// does by default on AArch64).
#include "kernels/fp_contract_off.h"

namespace ef::kernels {
namespace {

constexpr float kPoison = -12345.0f;

// A reference level: maps with padded strides, projected through a pinhole camera.
struct RefMaps {
  int w = 0, h = 0;
  float fx = 0, fy = 0, cx = 0, cy = 0;
  std::ptrdiff_t vs = 0, ns = 0, is = 0, gxs = 0, gys = 0;
  std::vector<float> vertex, normal, intensity, gx, gy;

  float* v(int x, int y) { return vertex.data() + y * vs + 3 * x; }
  float* n(int x, int y) { return normal.data() + y * ns + 3 * x; }
};

RefMaps make_ref(int w, int h, uint32_t seed) {
  RefMaps r;
  r.w = w;
  r.h = h;
  r.fx = r.fy = 0.9f * static_cast<float>(w);
  r.cx = 0.5f * static_cast<float>(w) - 0.5f;
  r.cy = 0.5f * static_cast<float>(h) - 0.5f;
  r.vs = 3 * w + 5;
  r.ns = 3 * w + 2;
  r.is = w + 3;
  r.gxs = w + 1;
  r.gys = w + 7;
  r.vertex.assign(static_cast<std::size_t>(r.vs * h), kPoison);
  r.normal.assign(static_cast<std::size_t>(r.ns * h), kPoison);
  r.intensity.assign(static_cast<std::size_t>(r.is * h), kPoison);
  r.gx.assign(static_cast<std::size_t>(r.gxs * h), kPoison);
  r.gy.assign(static_cast<std::size_t>(r.gys * h), kPoison);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float z = 1.2f + 0.4f * std::sin(0.3f * static_cast<float>(x)) * std::cos(0.2f * static_cast<float>(y));
      const bool hole = (x * 7 + y * 3) % 23 == 0;
      float* v = r.v(x, y);
      v[0] = hole ? 0.0f : (static_cast<float>(x) - r.cx) * z / r.fx;
      v[1] = hole ? 0.0f : (static_cast<float>(y) - r.cy) * z / r.fy;
      v[2] = hole ? 0.0f : z;
      float nn[3] = {0.4f * u(rng), 0.4f * u(rng), -1.0f};
      const float len = std::sqrt(nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]);
      const bool no_normal = hole || (x * 5 + y * 11) % 29 == 0;
      for (int k = 0; k < 3; ++k) r.n(x, y)[k] = no_normal ? 0.0f : nn[k] / len;
      r.intensity[y * r.is + x] =
          128.0f + 100.0f * std::sin(0.37f * static_cast<float>(x) + 0.21f * static_cast<float>(y));
      r.gx[y * r.gxs + x] = 30.0f * u(rng);
      r.gy[y * r.gys + x] = 30.0f * u(rng);
    }
  return r;
}

TrackRowsParams params_for(const RefMaps& r) {
  TrackRowsParams p;
  p.fx = r.fx;
  p.fy = r.fy;
  p.cx = r.cx;
  p.cy = r.cy;
  p.width = r.w;
  p.height = r.h;
  p.ref_vertex = r.vertex.data();
  p.ref_normal = r.normal.data();
  p.ref_intensity = r.intensity.data();
  p.ref_grad_x = r.gx.data();
  p.ref_grad_y = r.gy.data();
  p.vertex_stride = r.vs;
  p.normal_stride = r.ns;
  p.intensity_stride = r.is;
  p.grad_x_stride = r.gxs;
  p.grad_y_stride = r.gys;
  p.icp_max_d2 = 0.1f * 0.1f;
  p.icp_sin2_max = 0.117f;  // sin^2(20 deg)
  p.rgb_huber_grey = 15.0f;
  p.rgb_max_depth_diff = 0.07f;
  p.rgb_max_depth = 6.0f;
  return p;
}

// Rotation about a unit-ish axis (Rodrigues, double) into P.R, and t.
void set_pose(TrackRowsParams& p, const double w[3], const double t[3]) {
  const double th = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
  const double k[3] = {th > 0 ? w[0] / th : 1, th > 0 ? w[1] / th : 0, th > 0 ? w[2] / th : 0};
  const double c = std::cos(th), s = std::sin(th), C = 1 - c;
  const double R[9] = {c + k[0] * k[0] * C,        k[0] * k[1] * C - k[2] * s, k[0] * k[2] * C + k[1] * s,
                       k[1] * k[0] * C + k[2] * s, c + k[1] * k[1] * C,        k[1] * k[2] * C - k[0] * s,
                       k[2] * k[0] * C - k[1] * s, k[2] * k[1] * C + k[0] * s, c + k[2] * k[2] * C};
  for (int i = 0; i < 9; ++i) p.R[i] = static_cast<float>(R[i]);
  for (int i = 0; i < 3; ++i) p.t[i] = static_cast<float>(t[i]);
}

// Current pixels: most are reference points moved into the current frame by the inverse pose (with
// noise), so they associate and pass or narrowly fail the gates; some are invalid, some random
// (behind the camera, outside the image), some normals are zero.
struct Current {
  std::size_t n = 0, offset = 0;
  std::vector<float> vertex, normal, intensity;
  const float* v() const { return vertex.data() + 3 * offset; }
  const float* nrm() const { return normal.data() + 3 * offset; }
  const float* in() const { return intensity.data() + offset; }
};

Current make_current(const RefMaps& r, const TrackRowsParams& p, std::size_t n, std::size_t offset, uint32_t seed) {
  Current c;
  c.n = n;
  c.offset = offset;
  c.vertex.assign(3 * (n + offset), kPoison);
  c.normal.assign(3 * (n + offset), kPoison);
  c.intensity.assign(n + offset, kPoison);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::uniform_int_distribution<int> px(0, r.w - 1), py(0, r.h - 1), kind(0, 19);
  std::normal_distribution<float> noise(0.0f, 0.02f);
  for (std::size_t j = 0; j < n; ++j) {
    float* v = c.vertex.data() + 3 * (offset + j);
    float* nn = c.normal.data() + 3 * (offset + j);
    const int k = kind(rng);
    float q[3], m[3];
    const int x = px(rng), y = py(rng);
    for (int i = 0; i < 3; ++i) {
      q[i] = r.vertex[y * r.vs + 3 * x + i];
      m[i] = r.normal[y * r.ns + 3 * x + i];
    }
    if (k == 0) {  // invalid vertex
      v[0] = u(rng);
      v[1] = u(rng);
      v[2] = 0.0f;
    } else if (k == 1) {  // anywhere, including behind the camera after the pose
      v[0] = 3.0f * u(rng);
      v[1] = 3.0f * u(rng);
      v[2] = 0.05f + 2.0f * (u(rng) + 1.0f);
    } else {
      // R^T (q - t) + noise: lands near q. Normals R^T m, noisier for some.
      const float d[3] = {q[0] - p.t[0] + noise(rng), q[1] - p.t[1] + noise(rng), q[2] - p.t[2] + noise(rng)};
      for (int i = 0; i < 3; ++i) v[i] = p.R[i] * d[0] + p.R[3 + i] * d[1] + p.R[6 + i] * d[2];
      if (q[2] <= 0.0f) v[2] = 0.5f + u(rng) * 0.1f;  // a hole in the reference: any valid point
      const float s = k == 2 ? 2.0f : 0.1f;
      for (int i = 0; i < 3; ++i) nn[i] = p.R[i] * m[0] + p.R[3 + i] * m[1] + p.R[6 + i] * m[2] + s * noise(rng);
    }
    if (k == 3) nn[0] = nn[1] = nn[2] = 0.0f;
    if (k < 2) {
      nn[0] = 0.3f * u(rng);
      nn[1] = 0.3f * u(rng);
      nn[2] = -1.0f;
    }
    c.intensity[offset + j] = 128.0f + 120.0f * u(rng);
  }
  return c;
}

// SoA rows with a poisoned gap after each component, `offset` floats into the allocation.
struct RowTile {
  std::size_t n = 0, stride = 0, offset = 0;
  std::vector<float> buf;
  RowTile(std::size_t n_, std::size_t stride_, std::size_t offset_)
      : n(n_), stride(stride_), offset(offset_), buf(offset_ + 8 * stride_ + 3, kPoison) {}
  float* data() { return buf.data() + offset; }
  float at(int k, std::size_t j) const { return buf[offset + k * stride + j]; }
};

std::string first_difference(const RowTile& a, const RowTile& b, const char* term) {
  if (a.buf.size() != b.buf.size()) return "sizes";
  for (std::size_t i = 0; i < a.buf.size(); ++i)
    if (std::memcmp(&a.buf[i], &b.buf[i], sizeof(float)) != 0) {
      char msg[200];
      const std::size_t rel = i - a.offset;
      std::snprintf(msg, sizeof msg, "%s: float %zu (component %zu, row %zu): %.9g vs %.9g", term, i, rel / a.stride,
                    rel % a.stride, static_cast<double>(a.buf[i]), static_cast<double>(b.buf[i]));
      return msg;
    }
  return "";
}

struct Output {
  RowTile icp, rgb;
  TrackRowsCounts counts;
};

Output run_variant(TrackRowsFn fn, const TrackRowsParams& p, const Current& c, std::size_t stride, std::size_t off) {
  Output o{RowTile(c.n, stride, off), RowTile(c.n, stride, off + 1), {}};
  o.counts.valid = 1;  // counts are added to
  fn(p, c.v(), p.use_icp ? c.nrm() : nullptr, p.use_rgb ? c.in() : nullptr, c.n, p.use_icp ? o.icp.data() : nullptr,
     p.use_rgb ? o.rgb.data() : nullptr, stride, &o.counts);
  return o;
}

// Returns the reference's counts (so callers can check the input exercised every path).
TrackRowsCounts expect_variants_equal_reference(const TrackRowsParams& p, const Current& c, const std::string& what,
                                                std::size_t stride_pad = 0) {
  const std::size_t stride = c.n + stride_pad;
  const Output want = run_variant(&track_rows_ref, p, c, stride, 2);
  for (const auto& v : kTrackRowsVariants) {
    if (!isa_available(v.isa, detected_cpu_features())) continue;
    const Output got = run_variant(v.fn, p, c, stride, 2);
    const std::string d = first_difference(got.icp, want.icp, "icp") + first_difference(got.rgb, want.rgb, "rgb");
    EXPECT_TRUE(d.empty()) << v.name << " differs from the reference (" << what << ", n=" << c.n << "): " << d;
    EXPECT_EQ(got.counts.valid, want.counts.valid) << v.name << " " << what;
    EXPECT_EQ(got.counts.icp, want.counts.icp) << v.name << " " << what;
    EXPECT_EQ(got.counts.rgb, want.counts.rgb) << v.name << " " << what;
  }
  TrackRowsCounts c0 = want.counts;
  c0.valid -= 1;
  return c0;
}

const std::size_t kTrackSizes[] = {0, 1, 2, 3, 4, 5, 7, 8, 9, 15, 16, 17, 31, 32, 33, 47, 48, 63, 64, 65, 100, 320, 643};

TEST(TrackRows, ReportVariants) {
  const auto ran = ef::test::runnable_variants(kTrackRowsVariants, "track_rows");
  EXPECT_FALSE(ran.empty());
  EXPECT_STREQ(track_rows_selected(), best_variant(kTrackRowsVariants, cpu_features()).name);
  std::printf("[ variants ] track_rows dispatches to %s\n", track_rows_selected());
}

TEST(TrackRows, EveryVariantEqualsReferenceBitForBit) {
  const RefMaps ref = make_ref(64, 48, 3);
  uint32_t seed = 10;
  TrackRowsCounts total;
  const double poses[][6] = {{0, 0, 0, 0, 0, 0},
                             {0.01, -0.02, 0.015, 0.02, -0.01, 0.03},
                             {0.05, 0.03, -0.04, -0.08, 0.1, 0.02},
                             {0.3, -0.2, 0.9, 0.4, -0.3, 0.5}};  // far: many points behind / outside
  for (const auto& pose : poses) {
    TrackRowsParams p = params_for(ref);
    set_pose(p, pose + 3, pose);
    for (std::size_t n : kTrackSizes) {
      const Current c = make_current(ref, p, n, n % 3, seed++);
      const TrackRowsCounts k = expect_variants_equal_reference(p, c, "joint");
      total.valid += k.valid;
      total.icp += k.icp;
      total.rgb += k.rgb;
      expect_variants_equal_reference(p, c, "joint, padded stride", 5);
      TrackRowsParams icp = p;
      icp.use_rgb = false;
      expect_variants_equal_reference(icp, c, "ICP only");
      TrackRowsParams rgb = p;
      rgb.use_icp = false;
      expect_variants_equal_reference(rgb, c, "RGB only");
      rgb.rgb_depth_gate = false;
      expect_variants_equal_reference(rgb, c, "RGB only, no depth gate");
    }
  }
  // The inputs exercise both terms: a good share of pixels passes and a good share fails each.
  std::printf("[ rows ] joint runs: %lld valid pixels, %lld ICP rows, %lld RGB rows\n",
              static_cast<long long>(total.valid), static_cast<long long>(total.icp),
              static_cast<long long>(total.rgb));
  EXPECT_GT(total.icp, total.valid / 5);
  EXPECT_LT(total.icp, total.valid * 9 / 10);
  EXPECT_GT(total.rgb, total.valid / 5);
  EXPECT_LT(total.rgb, total.valid * 9 / 10);
}

TEST(TrackRows, GatesAtTheirLimitsAgreeToo) {
  // Tight and loose gates move many pixels across the thresholds.
  const RefMaps ref = make_ref(40, 30, 8);
  TrackRowsParams p = params_for(ref);
  const double w[3] = {0.01, 0.02, -0.01}, t[3] = {0.01, 0.0, -0.02};
  set_pose(p, w, t);
  const Current c = make_current(ref, p, 1000, 1, 99);
  for (float d2 : {1e-6f, 4e-4f, 1.0f})
    for (float s2 : {1e-4f, 0.03f, 1.0f})
      for (float huber : {0.5f, 15.0f, 1e6f}) {
        TrackRowsParams q = p;
        // The texture gate: off, passing a share of the pixels (gradients up to 30 grey levels per
        // pixel in each direction), passing none.
        q.rgb_min_grad2 = huber == 0.5f ? 0.0f : huber == 15.0f ? 300.0f : 1e6f;
        q.icp_max_d2 = d2;
        q.icp_sin2_max = s2;
        q.rgb_huber_grey = huber;
        q.rgb_max_depth_diff = d2 * 10;
        q.rgb_max_depth = 1.3f;
        expect_variants_equal_reference(q, c, "gates " + std::to_string(d2) + " " + std::to_string(s2));
      }
}

TEST(TrackRows, ReferenceFollowsTheFormulas) {
  // Identity pose, 8x8 reference; current pixel 0 = the reference point at pixel (3, 2) moved 2 cm
  // along z. Reference intensity I = 10 x + 100 + 20 y: bilinear interpolation is exact.
  RefMaps ref = make_ref(8, 8, 1);
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 8; ++x) {
      ref.intensity[y * ref.is + x] = 10.0f * static_cast<float>(x) + 100.0f + 20.0f * static_cast<float>(y);
      ref.gx[y * ref.gxs + x] = 10.0f;
      ref.gy[y * ref.gys + x] = 20.0f;
      float* n = ref.n(x, y);
      n[0] = 0.0f;
      n[1] = 0.0f;
      n[2] = -1.0f;
    }
  TrackRowsParams p = params_for(ref);
  const float* q = ref.v(3, 2);
  ASSERT_GT(q[2], 0.0f);
  // Pixel 0: the point 2 cm behind q on the same ray (projects to pixel (3, 2) exactly).
  // Pixel 1: invalid vertex. Pixel 2: 20 cm behind (fails the ICP distance and the depth gate).
  // Pixel 3: normal at 30 degrees to the reference normal (fails the normal gate only).
  const float s = (q[2] + 0.02f) / q[2], s2 = (q[2] + 0.2f) / q[2];
  const float th = 30.0f * 3.14159265f / 180.0f;
  std::vector<float> v = {q[0] * s, q[1] * s, q[2] * s, 0, 0, 0, q[0] * s2, q[1] * s2, q[2] * s2, q[0], q[1], q[2]};
  std::vector<float> n = {0, 0, -1, 0, 0, -1, 0, 0, -1, std::sin(th), 0, -std::cos(th)};
  std::vector<float> in = {50.0f, 1.0f, 2.0f, 130.0f + 40.0f};
  RowTile icp(4, 4, 0), rgb(4, 4, 0);
  TrackRowsCounts counts;
  track_rows_ref(p, v.data(), n.data(), in.data(), 4, icp.data(), rgb.data(), 4, &counts);
  EXPECT_EQ(counts.valid, 3);
  EXPECT_EQ(counts.icp, 1);
  EXPECT_EQ(counts.rgb, 2);  // pixels 0 and 3
  // ICP row of pixel 0: J = (m, X x m) with m = (0, 0, -1); r = m . (X - q) = -0.02 (rounded).
  const float X[3] = {v[0], v[1], v[2]};
  EXPECT_EQ(icp.at(0, 0), 0.0f);
  EXPECT_EQ(icp.at(1, 0), 0.0f);
  EXPECT_EQ(icp.at(2, 0), -1.0f);
  EXPECT_FLOAT_EQ(icp.at(3, 0), -X[1]);
  EXPECT_FLOAT_EQ(icp.at(4, 0), X[0]);
  EXPECT_EQ(icp.at(5, 0), 0.0f);
  EXPECT_NEAR(icp.at(6, 0), -0.02f, 1e-6f);
  EXPECT_EQ(icp.at(7, 0), 1.0f);
  // Rejected rows are zeros in every component.
  for (std::size_t j : {std::size_t{1}, std::size_t{2}, std::size_t{3}})
    for (int k = 0; k < 8; ++k) EXPECT_EQ(icp.at(k, j), 0.0f) << "icp row " << j << " component " << k;
  for (std::size_t j : {std::size_t{1}, std::size_t{2}})
    for (int k = 0; k < 8; ++k) EXPECT_EQ(rgb.at(k, j), 0.0f) << "rgb row " << j << " component " << k;
  // RGB row of pixel 0: I_ref at (3, 2) = 170, r = 170 - 50 = 120 beyond Huber 15: w = 15 / 120.
  EXPECT_NEAR(rgb.at(6, 0), 120.0f, 1e-3f);
  EXPECT_NEAR(rgb.at(7, 0), 15.0f / 120.0f, 1e-6f);
  const float iz = 1.0f / X[2];
  EXPECT_NEAR(rgb.at(0, 0), 10.0f * p.fx * iz, 1e-3f);
  EXPECT_NEAR(rgb.at(1, 0), 20.0f * p.fy * iz, 1e-3f);
  EXPECT_NEAR(rgb.at(2, 0), -(rgb.at(0, 0) * X[0] + rgb.at(1, 0) * X[1]) * iz, 1e-3f);
  // Pixel 3: residual 170 - 170 = 0 (inside Huber): weight 1.
  EXPECT_NEAR(rgb.at(6, 3), 0.0f, 1e-3f);
  EXPECT_EQ(rgb.at(7, 3), 1.0f);
  // Without the depth gate pixel 2 gets an RGB row too (it projects inside the image).
  p.rgb_depth_gate = false;
  p.use_icp = false;
  TrackRowsCounts c2;
  track_rows_ref(p, v.data(), nullptr, in.data(), 4, nullptr, rgb.data(), 4, &c2);
  EXPECT_EQ(c2.rgb, 3);
  EXPECT_EQ(c2.icp, 0);
  // The texture gate: the gradient is (10, 20) grey levels per pixel everywhere, |g|^2 = 500 exactly.
  p.rgb_min_grad2 = 500.0f;
  TrackRowsCounts c3;
  track_rows_ref(p, v.data(), nullptr, in.data(), 4, nullptr, rgb.data(), 4, &c3);
  EXPECT_EQ(c3.rgb, 3);
  p.rgb_min_grad2 = 501.0f;
  TrackRowsCounts c4;
  track_rows_ref(p, v.data(), nullptr, in.data(), 4, nullptr, rgb.data(), 4, &c4);
  EXPECT_EQ(c4.rgb, 0);
  for (std::size_t j = 0; j < 4; ++j)
    for (int k = 0; k < 8; ++k) EXPECT_EQ(rgb.at(k, j), 0.0f) << "gated rgb row " << j << " component " << k;
}

// The same fixed input gives the same bits on x86-64 and AArch64 (FNV-1a over both row arrays and
// the counts). Inputs come from integer arithmetic only, so they are identical everywhere.
TEST(TrackRows, SameBitsOnEveryArchitecture) {
  RefMaps ref;
  ref.w = 24;
  ref.h = 18;
  ref.fx = ref.fy = 20.0f;
  ref.cx = 11.5f;
  ref.cy = 8.5f;
  ref.vs = ref.ns = 3 * 24;
  ref.is = ref.gxs = ref.gys = 24;
  const std::size_t pixels = 24 * 18;
  ref.vertex.resize(3 * pixels);
  ref.normal.resize(3 * pixels);
  ref.intensity.resize(pixels);
  ref.gx.resize(pixels);
  ref.gy.resize(pixels);
  uint32_t state = 2463534242u;
  auto next = [&state] {  // xorshift32
    state ^= state << 13;
    state ^= state >> 17;
    state ^= state << 5;
    return state;
  };
  auto unit = [&next] { return static_cast<float>(next() % 2001) * 0.001f - 1.0f; };  // [-1, 1], 1e-3 steps
  for (int y = 0; y < ref.h; ++y)
    for (int x = 0; x < ref.w; ++x) {
      const float z = next() % 17 == 0 ? 0.0f : 1.0f + 0.25f * unit();
      float* v = ref.v(x, y);
      v[0] = (static_cast<float>(x) - ref.cx) * z / ref.fx;
      v[1] = (static_cast<float>(y) - ref.cy) * z / ref.fy;
      v[2] = z;
      float* n = ref.n(x, y);
      n[0] = 0.3f * unit();
      n[1] = 0.3f * unit();
      n[2] = next() % 13 == 0 ? 0.0f : -1.0f;
      if (n[2] == 0.0f) n[0] = n[1] = 0.0f;
      ref.intensity[y * ref.is + x] = 128.0f + 127.0f * unit();
      ref.gx[y * ref.gxs + x] = 20.0f * unit();
      ref.gy[y * ref.gys + x] = 20.0f * unit();
    }
  TrackRowsParams p = params_for(ref);
  const float R[9] = {0.999f, -0.02f, 0.03f, 0.021f, 0.998f, -0.01f, -0.03f, 0.011f, 0.999f};
  std::memcpy(p.R, R, sizeof R);
  p.t[0] = 0.01f;
  p.t[1] = -0.02f;
  p.t[2] = 0.015f;
  const std::size_t n = 997;
  std::vector<float> v(3 * n), nn(3 * n), in(n);
  for (std::size_t j = 0; j < n; ++j) {
    const std::size_t px = next() % pixels;
    for (int k = 0; k < 3; ++k) {
      v[3 * j + k] = ref.vertex[3 * px + k] + 0.03f * unit();
      nn[3 * j + k] = ref.normal[3 * px + k] + 0.2f * unit();
    }
    if (next() % 11 == 0) v[3 * j + 2] = 0.0f;
    in[j] = 128.0f + 127.0f * unit();
  }
  RowTile icp(n, n, 0), rgb(n, n, 0);
  TrackRowsCounts counts;
  track_rows_ref(p, v.data(), nn.data(), in.data(), n, icp.data(), rgb.data(), n, &counts);
  for (const auto& var : kTrackRowsVariants) {
    if (!isa_available(var.isa, detected_cpu_features())) continue;
    RowTile i2(n, n, 0), r2(n, n, 0);
    TrackRowsCounts c2;
    var.fn(p, v.data(), nn.data(), in.data(), n, i2.data(), r2.data(), n, &c2);
    EXPECT_EQ(first_difference(i2, icp, "icp") + first_difference(r2, rgb, "rgb"), "") << var.name;
  }
  uint64_t h = 1469598103934665603ull;
  auto mix = [&h](const void* ptr, std::size_t bytes) {
    for (std::size_t i = 0; i < bytes; ++i) h = (h ^ static_cast<const unsigned char*>(ptr)[i]) * 1099511628211ull;
  };
  mix(icp.buf.data(), icp.buf.size() * sizeof(float));
  mix(rgb.buf.data(), rgb.buf.size() * sizeof(float));
  mix(&counts, sizeof counts);
  std::printf("[ bits ] track_rows fixed-input hash %016llx (valid %lld, icp %lld, rgb %lld)\n",
              static_cast<unsigned long long>(h), static_cast<long long>(counts.valid),
              static_cast<long long>(counts.icp), static_cast<long long>(counts.rgb));
  EXPECT_GT(counts.icp, 100);
  EXPECT_GT(counts.rgb, 100);
  EXPECT_EQ(h, 0x389bf74dd22fa9f1ull) << "hash of the reference's output bits changed";
}

}  // namespace
}  // namespace ef::kernels
