// Internal to the SIMD variants of track_rows: the per-pixel maths of kernels/track_rows.h written
// once over a small vector-ops type that each ISA file defines with its intrinsics, branch-free over
// the lanes (gates become masks, rejected lanes are zeroed). Internal linkage throughout (anonymous
// namespace): each ISA file compiles its own copy with its own flags (the rule in kernels/variants.h);
// the tail of a run goes to track_rows_ref, compiled for the baseline.
//
// A vector-ops type V provides (F: kWidth floats, I: kWidth int32, M: a lane mask):
//   set1(float) zero() load(p) store(p, F)
//   load3(p, x, y, z): kWidth xyz triples (3 kWidth floats; the f32_ops types' de-interleave)
//   add sub mul div neg abs floor  cvtt(F) -> I (truncation)  cvt(I) -> F
//   iset1(int) iadd(I, I) imul(I, I)
//   lt le gt ge (ordered: false on NaN, as C++'s < <= > >=)  ne (unordered: true on NaN, as !=)
//   land lor (masks)  any(M) count(M)  keep(M, F): lane or +0  ikeep(M, I): lane or 0
//   gather(base, I): base[idx] per lane (every idx must be a valid offset)
//   gather2(base, I, lo, hi): lo = base[idx], hi = base[idx + 1] per lane (one 64-bit load per lane:
//   the two bilinear taps of an image row, or x and y of a vertex)
// Every float operation is the single IEEE operation of the reference in the same order, so each lane
// is bit-identical to track_rows_ref.
#pragma once

#include <cstddef>
#include <cstdint>

#include "kernels/track_rows_variants.h"

#include "kernels/fp_contract_off.h"

namespace ef::kernels {
namespace {

template <class V>
struct TrVec3 {
  typename V::F x, y, z;
};

template <class V>
inline typename V::F tr_dot(const TrVec3<V>& a, const TrVec3<V>& b) {
  return V::add(V::add(V::mul(a.x, b.x), V::mul(a.y, b.y)), V::mul(a.z, b.z));
}

template <class V>
inline TrVec3<V> tr_cross(const TrVec3<V>& a, const TrVec3<V>& b) {
  return {V::sub(V::mul(a.y, b.z), V::mul(a.z, b.y)), V::sub(V::mul(a.z, b.x), V::mul(a.x, b.z)),
          V::sub(V::mul(a.x, b.y), V::mul(a.y, b.x))};
}

template <class V>
inline void tr_store_row(float* rows, std::size_t stride, typename V::M m, const typename V::F J[6], typename V::F r,
                         typename V::F w) {
  for (int k = 0; k < 6; ++k) V::store(rows + k * stride, V::keep(m, J[k]));
  V::store(rows + 6 * stride, V::keep(m, r));
  V::store(rows + 7 * stride, V::keep(m, w));
}

template <class V>
inline void tr_store_zero(float* rows, std::size_t stride) {
  const typename V::F z = V::zero();
  for (int k = 0; k < 8; ++k) V::store(rows + k * stride, z);
}

template <class V>
void track_rows_simd(const TrackRowsParams& P, const float* cur_vertex, const float* cur_normal,
                     const float* cur_intensity, std::size_t n, float* icp_rows, float* rgb_rows, std::size_t stride,
                     TrackRowsCounts* counts) {
  using F = typename V::F;
  using I = typename V::I;
  using M = typename V::M;
  constexpr int W = V::kWidth;
  F R[9];
  for (int k = 0; k < 9; ++k) R[k] = V::set1(P.R[k]);
  const F tx = V::set1(P.t[0]), ty = V::set1(P.t[1]), tz = V::set1(P.t[2]);
  const F fx = V::set1(P.fx), fy = V::set1(P.fy), cx = V::set1(P.cx), cy = V::set1(P.cy);
  const F zero = V::zero(), one = V::set1(1.0f), half = V::set1(0.5f), minus_half = V::set1(-0.5f);
  const F u_in_max = V::set1(static_cast<float>(P.width) - 0.5f);
  const F v_in_max = V::set1(static_cast<float>(P.height) - 0.5f);
  const F u_bi_max = V::set1(static_cast<float>(P.width - 1));
  const F v_bi_max = V::set1(static_cast<float>(P.height - 1));
  const F max_d2 = V::set1(P.icp_max_d2), sin2_max = V::set1(P.icp_sin2_max);
  const F huber = V::set1(P.rgb_huber_grey), max_dd = V::set1(P.rgb_max_depth_diff);
  const F max_depth = V::set1(P.rgb_max_depth);
  const F min_grad2 = V::set1(P.rgb_min_grad2);
  const I three = V::iset1(3);
  const I vstride = V::iset1(static_cast<int>(P.vertex_stride));
  const I nstride = V::iset1(static_cast<int>(P.normal_stride));
  const I istride = V::iset1(static_cast<int>(P.intensity_stride));
  const I gxstride = V::iset1(static_cast<int>(P.grad_x_stride));
  const I gystride = V::iset1(static_cast<int>(P.grad_y_stride));
  const bool need_q = P.use_icp || (P.use_rgb && P.rgb_depth_gate);
  int64_t valid_count = 0, icp_count = 0, rgb_count = 0;

  std::size_t j = 0;
  for (; j + W <= n; j += W) {
    float* icp = P.use_icp ? icp_rows + j : nullptr;
    float* rgb = P.use_rgb ? rgb_rows + j : nullptr;
    TrVec3<V> p;
    V::load3(cur_vertex + 3 * j, p.x, p.y, p.z);
    const M valid = V::gt(p.z, zero);
    if (!V::any(valid)) {
      if (P.use_icp) tr_store_zero<V>(icp, stride);
      if (P.use_rgb) tr_store_zero<V>(rgb, stride);
      continue;
    }
    valid_count += V::count(valid);
    const TrVec3<V> X = {V::add(V::add(V::add(V::mul(R[0], p.x), V::mul(R[1], p.y)), V::mul(R[2], p.z)), tx),
                         V::add(V::add(V::add(V::mul(R[3], p.x), V::mul(R[4], p.y)), V::mul(R[5], p.z)), ty),
                         V::add(V::add(V::add(V::mul(R[6], p.x), V::mul(R[7], p.y)), V::mul(R[8], p.z)), tz)};
    const M front = V::land(valid, V::gt(X.z, zero));
    const F iz = V::div(one, X.z);
    const F u = V::add(V::mul(V::mul(fx, X.x), iz), cx);
    const F v = V::add(V::mul(V::mul(fy, X.y), iz), cy);

    // Nearest reference pixel; lanes outside read pixel (0, 0) and are masked.
    M q_valid = V::land(front, V::lt(zero, zero));  // all false until the gather below
    I ui = V::iset1(0), vi = V::iset1(0), vidx = V::iset1(0);
    F qz = zero;
    if (need_q) {
      const M inside =
          V::land(V::land(V::land(front, V::gt(u, minus_half)), V::land(V::gt(v, minus_half), V::lt(u, u_in_max))),
                  V::lt(v, v_in_max));
      if (V::any(inside)) {
        ui = V::ikeep(inside, V::cvtt(V::floor(V::add(u, half))));
        vi = V::ikeep(inside, V::cvtt(V::floor(V::add(v, half))));
        vidx = V::iadd(V::imul(vi, vstride), V::imul(ui, three));
        qz = V::gather(P.ref_vertex + 2, vidx);
        q_valid = V::land(inside, V::gt(qz, zero));
      }
    }

    if (P.use_icp) {
      TrVec3<V> cn;
      V::load3(cur_normal + 3 * j, cn.x, cn.y, cn.z);
      M m = V::land(q_valid, V::lor(V::lor(V::ne(cn.x, zero), V::ne(cn.y, zero)), V::ne(cn.z, zero)));
      if (V::any(m)) {
        const I nidx = V::iadd(V::imul(vi, nstride), V::imul(ui, three));
        TrVec3<V> q, nr;
        V::gather2(P.ref_vertex, vidx, q.x, q.y);
        q.z = qz;
        V::gather2(P.ref_normal, nidx, nr.x, nr.y);
        nr.z = V::gather(P.ref_normal + 2, nidx);
        m = V::land(m, V::lor(V::lor(V::ne(nr.x, zero), V::ne(nr.y, zero)), V::ne(nr.z, zero)));
        const TrVec3<V> d = {V::sub(X.x, q.x), V::sub(X.y, q.y), V::sub(X.z, q.z)};
        const TrVec3<V> Rn = {V::add(V::add(V::mul(R[0], cn.x), V::mul(R[1], cn.y)), V::mul(R[2], cn.z)),
                              V::add(V::add(V::mul(R[3], cn.x), V::mul(R[4], cn.y)), V::mul(R[5], cn.z)),
                              V::add(V::add(V::mul(R[6], cn.x), V::mul(R[7], cn.y)), V::mul(R[8], cn.z))};
        const TrVec3<V> c = tr_cross<V>(Rn, nr);
        m = V::land(m, V::land(V::le(tr_dot<V>(d, d), max_d2),
                               V::land(V::gt(tr_dot<V>(Rn, nr), zero), V::le(tr_dot<V>(c, c), sin2_max))));
        const TrVec3<V> xn = tr_cross<V>(X, nr);
        const F J[6] = {nr.x, nr.y, nr.z, xn.x, xn.y, xn.z};
        tr_store_row<V>(icp, stride, m, J, tr_dot<V>(nr, d), one);
        icp_count += V::count(m);
      } else {
        tr_store_zero<V>(icp, stride);
      }
    }

    if (P.use_rgb) {
      M m = V::land(V::land(V::land(front, V::le(X.z, max_depth)), V::land(V::ge(u, zero), V::ge(v, zero))),
                    V::land(V::lt(u, u_bi_max), V::lt(v, v_bi_max)));
      if (P.rgb_depth_gate) m = V::land(m, V::land(q_valid, V::le(V::abs(V::sub(qz, X.z)), max_dd)));
      if (V::any(m)) {
        const I x0 = V::ikeep(m, V::cvtt(u)), y0 = V::ikeep(m, V::cvtt(v));
        const F ax = V::sub(u, V::cvt(x0)), ay = V::sub(v, V::cvt(y0));
        const F bx = V::sub(one, ax), by = V::sub(one, ay);
        const F w00 = V::mul(bx, by), w10 = V::mul(ax, by), w01 = V::mul(bx, ay), w11 = V::mul(ax, ay);
        const auto bilinear = [&](const float* im, I s) {
          const I i00 = V::iadd(V::imul(y0, s), x0);
          F a00, a10, a01, a11;
          V::gather2(im, i00, a00, a10);
          V::gather2(im, V::iadd(i00, s), a01, a11);
          return V::add(V::add(V::add(V::mul(w00, a00), V::mul(w10, a10)), V::mul(w01, a01)), V::mul(w11, a11));
        };
        const F bgx = bilinear(P.ref_grad_x, gxstride), bgy = bilinear(P.ref_grad_y, gystride);
        m = V::land(m, V::ge(V::add(V::mul(bgx, bgx), V::mul(bgy, bgy)), min_grad2));
        const F r = V::sub(bilinear(P.ref_intensity, istride), V::load(cur_intensity + j));
        const F gx = V::mul(V::mul(bgx, fx), iz);
        const F gy = V::mul(V::mul(bgy, fy), iz);
        const TrVec3<V> g = {gx, gy, V::neg(V::mul(V::add(V::mul(gx, X.x), V::mul(gy, X.y)), iz))};
        const TrVec3<V> xg = tr_cross<V>(X, g);
        const F J[6] = {g.x, g.y, g.z, xg.x, xg.y, xg.z};
        const F a = V::abs(r);
        // Huber: 1 inside, k / |r| beyond (the quotient of lanes inside is discarded).
        const F w = V::select(V::le(a, huber), one, V::div(huber, a));
        tr_store_row<V>(rgb, stride, m, J, r, w);
        rgb_count += V::count(m);
      } else {
        tr_store_zero<V>(rgb, stride);
      }
    }
  }
  counts->valid += valid_count;
  counts->icp += icp_count;
  counts->rgb += rgb_count;
  if (j < n)
    track_rows_ref(P, cur_vertex + 3 * j, cur_normal ? cur_normal + 3 * j : nullptr,
                   cur_intensity ? cur_intensity + j : nullptr, n - j, icp_rows ? icp_rows + j : nullptr,
                   rgb_rows ? rgb_rows + j : nullptr, stride, counts);
}

}  // namespace
}  // namespace ef::kernels
