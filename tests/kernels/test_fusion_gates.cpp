// fusion_gates: the reference follows its contract on hand-made cells (each bit of the code on its
// own), and every variant the CPU can run writes the same codes as the reference, bit for bit (random
// rows with empty, valid and stale ids, surfels in front of, at and behind the pixel, NaN normals and
// depths, projections on and off the pixel's own index pixel, every start and end of a run).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "kernel_test_util.h"
#include "kernels/fusion_gates.h"
#include "kernels/fusion_gates_variants.h"

namespace ef::kernels {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// Three index rows and one row of pixels, width w.
struct GateRows {
  int w;
  std::vector<int32_t> id[3];
  std::vector<float> depth[3], surface[3];
  std::vector<float> xi, yi, z, gate, nwx, nwy, nwz;
  explicit GateRows(int w_) : w(w_), xi(w_), yi(w_), z(w_), gate(w_), nwx(w_), nwy(w_), nwz(w_) {
    for (int r = 0; r < 3; ++r) {
      id[r].assign(w, -1);
      depth[r].assign(w, 0.0f);
      surface[r].assign(4 * w, 0.0f);
    }
    for (int x = 0; x < w; ++x) {
      xi[x] = static_cast<float>(x);
      yi[x] = 5.0f;
      z[x] = 2.0f;
      gate[x] = 0.05f;
      nwz[x] = -1.0f;
    }
  }
  FusionGateParams params(int32_t pool_size) const {
    FusionGateParams p;
    for (int r = 0; r < 3; ++r) {
      p.id[r] = id[r].data();
      p.depth[r] = depth[r].data();
      p.surface[r] = surface[r].data();
    }
    p.pool_size = pool_size;
    p.neg_free_space_factor = -2.0f;
    p.cos_normal_gate = 0.8660254f;
    p.y = 5;
    return p;
  }
  FusionGateRow row() const {
    FusionGateRow g;
    g.xi = xi.data();
    g.yi = yi.data();
    g.z = z.data();
    g.gate = gate.data();
    g.nwx = nwx.data();
    g.nwy = nwy.data();
    g.nwz = nwz.data();
    return g;
  }
  // A surfel in cell (x, row r) at depth d with unit normal n and confidence 5.
  void put(int r, int x, int32_t sid, float d, float nx, float ny, float nz) {
    id[r][x] = sid;
    depth[r][x] = d;
    float* s = &surface[r][4 * x];
    s[0] = nx;
    s[1] = ny;
    s[2] = nz;
    s[3] = 5.0f;
  }
};

uint32_t ref_code(const GateRows& rows, int32_t pool_size, int x) {
  std::vector<uint32_t> code(rows.w, 0xDEADBEEFu);
  fusion_gates_ref(rows.params(pool_size), rows.row(), x, x + 1, code.data());
  return code[x];
}

TEST(FusionGates, ReferenceSetsEachBitAsTheContractSays) {
  GateRows rows(8);
  const int x = 3;
  // Nothing around the pixel: only the identity bit.
  EXPECT_EQ(ref_code(rows, 100, x), kGateIdentity);
  // Its own cell (k = 4): a surfel at its depth, facing the same way.
  rows.put(1, x, 7, 2.0f, 0.0f, 0.0f, -1.0f);
  uint32_t c = ref_code(rows, 100, x);
  EXPECT_EQ(c & kGateCells, kGateOwnCell);
  EXPECT_EQ((c >> kGateDepthShift) & kGateCells, kGateOwnCell);
  EXPECT_EQ((c >> kGateNormalShift) & kGateCells, kGateOwnCell);
  EXPECT_EQ(c & (kGateOwnViolated | kGateInvalid), 0u);
  // Cell k = 0 (up-left): 4 cm behind the pixel (within the 5 cm gate) but tilted 60 degrees.
  rows.put(0, x - 1, 8, 2.04f, 0.8660254f, 0.0f, -0.5f);
  c = ref_code(rows, 100, x);
  EXPECT_EQ(c & kGateCells, kGateOwnCell | 1u);
  EXPECT_EQ((c >> kGateDepthShift) & 1u, 1u);
  EXPECT_EQ((c >> kGateNormalShift) & 1u, 0u);
  // Cell k = 8 (down-right): 6 cm behind: outside the depth gate, not a violation.
  rows.put(2, x + 1, 9, 2.06f, 0.0f, 0.0f, -1.0f);
  c = ref_code(rows, 100, x);
  EXPECT_EQ((c >> 8) & 1u, 1u);
  EXPECT_EQ((c >> (kGateDepthShift + 8)) & 1u, 0u);
  EXPECT_EQ((c >> (kGateNormalShift + 8)) & 1u, 1u);
  EXPECT_EQ(c & kGateOwnViolated, 0u);
  // The own surfel 11 cm in front (more than two gates): violated, not within the depth gate.
  rows.put(1, x, 7, 1.89f, 0.0f, 0.0f, -1.0f);
  c = ref_code(rows, 100, x);
  EXPECT_NE(c & kGateOwnViolated, 0u);
  EXPECT_EQ((c >> kGateDepthShift) & kGateOwnCell, 0u);
  // 9 cm in front: outside the gate, not yet a violation.
  rows.put(1, x, 7, 1.91f, 0.0f, 0.0f, -1.0f);
  c = ref_code(rows, 100, x);
  EXPECT_EQ(c & kGateOwnViolated, 0u);
  EXPECT_EQ((c >> kGateDepthShift) & kGateOwnCell, 0u);
  // An id beyond the pool (cell k = 5): invalid, not occupied, no gate bits.
  rows.put(1, x + 1, 100, 2.0f, 0.0f, 0.0f, -1.0f);
  c = ref_code(rows, 100, x);
  EXPECT_NE(c & kGateInvalid, 0u);
  EXPECT_EQ((c >> 5) & 1u, 0u);
  EXPECT_EQ((c >> (kGateDepthShift + 5)) & 1u, 0u);
  EXPECT_EQ(ref_code(rows, 101, x) & kGateInvalid, 0u);  // a pool one larger holds it
  // The projection more than half a pixel off: no identity (the window of a centre c starts at
  // ceil(c - 0.5), so 3.5 is still pixel 3's and 2.5 pixel 2's).
  rows.xi[x] = 3.5001f;
  EXPECT_EQ(ref_code(rows, 100, x) & kGateIdentity, 0u);
  rows.xi[x] = 3.5f;
  EXPECT_NE(ref_code(rows, 100, x) & kGateIdentity, 0u);
  rows.xi[x] = 2.5f;
  EXPECT_EQ(ref_code(rows, 100, x) & kGateIdentity, 0u);
  rows.xi[x] = 2.5001f;
  EXPECT_NE(ref_code(rows, 100, x) & kGateIdentity, 0u);
  rows.yi[x] = 4.5f;  // ceil(4.0) = 4: the row above
  EXPECT_EQ(ref_code(rows, 100, x) & kGateIdentity, 0u);
}

// Random rows: every kind of cell, NaN among the inputs.
GateRows random_rows(std::mt19937& rng, int w, int32_t pool_size) {
  GateRows rows(w);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f), d(0.5f, 4.0f), off(-0.6f, 0.6f);
  std::uniform_int_distribution<int> kind(0, 19);
  std::uniform_int_distribution<int32_t> sid(0, pool_size - 1);
  for (int r = 0; r < 3; ++r)
    for (int x = 0; x < w; ++x) {
      const int k = kind(rng);
      float* s = &rows.surface[r][4 * x];
      for (int c = 0; c < 4; ++c) s[c] = u(rng);  // garbage where empty, as in a real index map
      if (k < 6) continue;                        // empty
      rows.id[r][x] = k == 6 ? pool_size + static_cast<int32_t>(x) : sid(rng);
      rows.depth[r][x] = d(rng);
      const float nx = u(rng) * 0.7f, ny = u(rng) * 0.7f, nz = -1.0f;
      const float len = std::sqrt(nx * nx + ny * ny + nz * nz);
      s[0] = nx / len;
      s[1] = ny / len;
      s[2] = nz / len;
      if (k == 7) s[1] = kNaN;
      if (k == 8) rows.depth[r][x] = kNaN;
    }
  for (int x = 0; x < w; ++x) {
    const int k = kind(rng);
    rows.z[x] = k == 0 ? kNaN : d(rng);
    // Surfels close to the pixel's depth for most cells, so that every gate outcome occurs.
    for (int r = 0; r < 3; ++r)
      if (kind(rng) < 12 && rows.id[r][x] >= 0 && std::isfinite(rows.depth[r][x]))
        rows.depth[r][x] = rows.z[x] + 0.1f * u(rng);
    rows.gate[x] = 0.01f + 0.008f * rows.z[x] * rows.z[x];
    rows.xi[x] = static_cast<float>(x) + (k < 14 ? 0.001f * u(rng) : off(rng));
    rows.yi[x] = 5.0f + (k == 1 ? 0.7f : 0.001f * u(rng));
    if (k == 2) rows.xi[x] = kNaN;
    const float nx = u(rng) * 0.7f, ny = u(rng) * 0.7f, nz = -1.0f;
    const float len = std::sqrt(nx * nx + ny * ny + nz * nz);
    rows.nwx[x] = nx / len;
    rows.nwy[x] = ny / len;
    rows.nwz[x] = k == 3 ? kNaN : nz / len;
  }
  return rows;
}

TEST(FusionGates, EveryVariantEqualsTheReferenceBitForBit) {
  const auto variants = test::runnable_variants(kFusionGatesVariants, "fusion_gates");
  const int32_t pool_size = 50000;
  for (int w : {3, 4, 5, 8, 9, 16, 17, 18, 33, 320}) {
    std::mt19937 rng(77u + static_cast<unsigned>(w));
    for (int rep = 0; rep < 20; ++rep) {
      const GateRows rows = random_rows(rng, w, pool_size);
      const FusionGateParams p = rows.params(pool_size);
      std::vector<uint32_t> want(w, 0xDEADBEEFu);
      fusion_gates_ref(p, rows.row(), 1, w - 1, want.data());
      uint32_t seen_bits = 0;
      for (int x = 1; x < w - 1; ++x) seen_bits |= want[x];
      if (w == 320) {  // the comparison below is not of codes that never vary
        EXPECT_EQ(seen_bits & (kGateIdentity | kGateInvalid | kGateOwnViolated),
                  kGateIdentity | kGateInvalid | kGateOwnViolated);
        EXPECT_EQ((seen_bits >> kGateDepthShift) & kGateCells, kGateCells);
        EXPECT_EQ((seen_bits >> kGateNormalShift) & kGateCells, kGateCells);
      }
      for (const auto* v : variants) {
        // Whole rows, and runs starting and ending anywhere (tails of every length).
        for (int begin : {1, 2, 3}) {
          for (int end : {w - 1, w - 2, std::min(w - 1, begin + 5)}) {
            if (end < begin) continue;
            std::vector<uint32_t> got(w, 0xDEADBEEFu);
            v->fn(p, rows.row(), begin, end, got.data());
            for (int x = 0; x < w; ++x) {
              const uint32_t expect = x >= begin && x < end ? want[x] : 0xDEADBEEFu;
              ASSERT_EQ(got[x], expect) << v->name << " width " << w << " run [" << begin << ", " << end << ") x "
                                        << x;
            }
          }
        }
      }
    }
  }
}

TEST(FusionGates, DispatchMatchesTheReference) {
  std::mt19937 rng(5u);
  const GateRows rows = random_rows(rng, 64, 1000);
  std::vector<uint32_t> a(64, 0), b(64, 0);
  fusion_gates(rows.params(1000), rows.row(), 1, 63, a.data());
  fusion_gates_ref(rows.params(1000), rows.row(), 1, 63, b.data());
  EXPECT_EQ(a, b);
  EXPECT_NE(fusion_gates_selected(), nullptr);
}

}  // namespace
}  // namespace ef::kernels
