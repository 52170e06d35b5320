#include "synth/det_math.h"

#include <cmath>
#include <cstdint>
#include <limits>

// Every operation below is a single exactly rounded IEEE double operation, evaluated in the order
// written (this file is compiled with -ffp-contract=off: no fused multiply-add). Do not rewrite
// a formula here without knowing that it changes every synthetic room's bits.

namespace ef::synth {

namespace {

// pi/2 split into three parts (Cody & Waite): the first two have 32 significant bits, so k * part
// is exact for |k| < 2^21 and x - k * pi/2 loses nothing to cancellation.
constexpr double kHalfPi1 = 0x1.921fb544p+0;
constexpr double kHalfPi2 = 0x1.0b4611a6p-34;
constexpr double kHalfPi3 = 0x1.3198a2e037073p-69;
constexpr double kTwoOverPi = 0.6366197723675814;
constexpr double kHalfPi = 1.5707963267948966;
constexpr double kPi = 3.141592653589793;
constexpr double kSixthPi = 0.5235987755982989;
constexpr double kSqrt3 = 1.7320508075688772;
constexpr double kTanTwelfthPi = 0.2679491924311227;  // tan(pi/12)

// Taylor series on |r| <= pi/4 (the truncation error is below 1e-19 there), Horner in r^2.
double sin_kernel(double r) {
  const double r2 = r * r;
  double p = -1.0 / 121645100408832000.0;   // -1/19!
  p = p * r2 + 1.0 / 355687428096000.0;     //  1/17!
  p = p * r2 - 1.0 / 1307674368000.0;       // -1/15!
  p = p * r2 + 1.0 / 6227020800.0;          //  1/13!
  p = p * r2 - 1.0 / 39916800.0;            // -1/11!
  p = p * r2 + 1.0 / 362880.0;              //  1/9!
  p = p * r2 - 1.0 / 5040.0;                // -1/7!
  p = p * r2 + 1.0 / 120.0;                 //  1/5!
  p = p * r2 - 1.0 / 6.0;                   // -1/3!
  return r + r * (r2 * p);
}

double cos_kernel(double r) {
  const double r2 = r * r;
  double p = 1.0 / 2432902008176640000.0;   //  1/20!
  p = p * r2 - 1.0 / 6402373705728000.0;    // -1/18!
  p = p * r2 + 1.0 / 20922789888000.0;      //  1/16!
  p = p * r2 - 1.0 / 87178291200.0;         // -1/14!
  p = p * r2 + 1.0 / 479001600.0;           //  1/12!
  p = p * r2 - 1.0 / 3628800.0;             // -1/10!
  p = p * r2 + 1.0 / 40320.0;               //  1/8!
  p = p * r2 - 1.0 / 720.0;                 // -1/6!
  p = p * r2 + 1.0 / 24.0;                  //  1/4!
  // 1 - r^2/2 + r^4 p, with the large terms added last.
  const double half_r2 = 0.5 * r2;
  return (1.0 - half_r2) + r2 * (r2 * p);
}

// atan(t) for |t| <= tan(pi/12) ~ 0.268: Taylor series to t^29 (truncation below 1e-18).
double atan_kernel(double t) {
  const double t2 = t * t;
  double p = -1.0 / 29.0;
  p = p * t2 + 1.0 / 27.0;
  p = p * t2 - 1.0 / 25.0;
  p = p * t2 + 1.0 / 23.0;
  p = p * t2 - 1.0 / 21.0;
  p = p * t2 + 1.0 / 19.0;
  p = p * t2 - 1.0 / 17.0;
  p = p * t2 + 1.0 / 15.0;
  p = p * t2 - 1.0 / 13.0;
  p = p * t2 + 1.0 / 11.0;
  p = p * t2 - 1.0 / 9.0;
  p = p * t2 + 1.0 / 7.0;
  p = p * t2 - 1.0 / 5.0;
  p = p * t2 + 1.0 / 3.0;
  return t - t * (t2 * p);
}

// atan(t) for 0 <= t <= 1.
double atan_unit(double t) {
  if (t <= kTanTwelfthPi) return atan_kernel(t);
  // atan(t) = pi/6 + atan((t sqrt3 - 1) / (t + sqrt3)); the argument lies in [-0.268, 0.268].
  return kSixthPi + atan_kernel((t * kSqrt3 - 1.0) / (t + kSqrt3));
}

}  // namespace

void det_sincos(double x, double& s, double& c) {
  if (!(std::fabs(x) < 1e6)) {
    s = c = std::numeric_limits<double>::quiet_NaN();
    return;
  }
  // Nearest multiple k of pi/2 (|k| < 2^20: the conversion is exact and in range).
  const double k = std::nearbyint(x * kTwoOverPi);
  const double r = ((x - k * kHalfPi1) - k * kHalfPi2) - k * kHalfPi3;
  const double sr = sin_kernel(r), cr = cos_kernel(r);
  const uint32_t quadrant = static_cast<uint32_t>(static_cast<int64_t>(k)) & 3u;
  switch (quadrant) {
    case 0: s = sr; c = cr; break;
    case 1: s = cr; c = -sr; break;
    case 2: s = -sr; c = -cr; break;
    default: s = -cr; c = sr; break;
  }
}

double det_sin(double x) {
  double s, c;
  det_sincos(x, s, c);
  return s;
}

double det_cos(double x) {
  double s, c;
  det_sincos(x, s, c);
  return c;
}

double det_atan2(double y, double x) {
  if (std::isnan(x) || std::isnan(y)) return std::numeric_limits<double>::quiet_NaN();
  const double ax = std::fabs(x), ay = std::fabs(y);
  if (ax == 0.0 && ay == 0.0) return 0.0;
  // Angle of (|x|, |y|) in [0, pi/2], from the ratio that is at most 1.
  double a;
  if (ay <= ax) {
    a = atan_unit(ay / ax);
  } else {
    a = kHalfPi - atan_unit(ax / ay);
  }
  if (x < 0) a = kPi - a;
  return y < 0 ? -a : a;
}

void det_sincosf(float x, float& s, float& c) {
  double sd, cd;
  det_sincos(static_cast<double>(x), sd, cd);
  s = static_cast<float>(sd);
  c = static_cast<float>(cd);
}

}  // namespace ef::synth
