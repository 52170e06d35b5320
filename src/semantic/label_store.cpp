#include "semantic/label_store.h"

#include <array>
#include <cfloat>
#include <cmath>
#include <cstring>

namespace ef::semantic {

namespace {
// round(nats / step) clamped to 0..255; nats >= 0 (NaN and +inf saturate).
uint8_t cost_from_nats(double nats) {
  const double units = nats / double(kLabelCostStep);
  if (!(units < double(kLabelCostMax) - 0.5)) return kLabelCostMax;
  if (units <= 0) return 0;
  return static_cast<uint8_t>(std::lround(units));
}
}  // namespace

void decode_labels(const uint8_t* costs, float* probs) {
  double sum = 0;
  double w[kLabelClasses];
  for (int c = 0; c < kLabelClasses; ++c) {
    w[c] = std::exp(-double(costs[c]) * double(kLabelCostStep));
    sum += w[c];
  }
  for (int c = 0; c < kLabelClasses; ++c) probs[c] = static_cast<float>(w[c] / sum);
}

void encode_labels(const float* probs, uint8_t* costs) {
  float pmax = 0;
  for (int c = 0; c < kLabelClasses; ++c)
    if (probs[c] > pmax) pmax = probs[c];
  for (int c = 0; c < kLabelBytes; ++c) costs[c] = 0;
  if (!(pmax > 0) || !std::isfinite(pmax)) return;  // no information: uniform
  for (int c = 0; c < kLabelClasses; ++c)
    costs[c] = probs[c] > 0 ? cost_from_nats(std::log(double(pmax)) - std::log(double(probs[c]))) : kLabelCostMax;
}

int label_argmax(const uint8_t* costs) {
  int best = 0;
  for (int c = 1; c < kLabelClasses; ++c)
    if (costs[c] < costs[best]) best = c;
  return best;
}

float label_argmax_probability(const uint8_t* costs) {
  float probs[kLabelClasses];
  decode_labels(costs, probs);
  return probs[label_argmax(costs)];
}

void label_summary(const uint8_t* stores, std::size_t n, uint8_t* class_id, float* class_prob) {
  for (std::size_t i = 0; i < n; ++i) {
    const uint8_t* costs = stores + i * kLabelBytes;
    class_id[i] = static_cast<uint8_t>(label_argmax(costs));
    class_prob[i] = label_argmax_probability(costs);
  }
}

namespace {
// Observation costs by table: for r = p_c / p_max in (0, 1], the cost depends on r's float exponent
// (2^-(kExponents-1) .. 2^0: below that every cost is 255) and the top 11 bits of its mantissa.
// Each entry is the exact rounding at its bucket's centre; a bucket spans ln(1 + 2^-11) / step =
// 0.0039 cost units, so a cost can differ from the exact rounding, by one unit, only where
// -ln(p_c / p_max) / step lies within 0.004 of a half-integer.
constexpr int kMantissaBits = 11;
// Exponents down to the first whose every ratio saturates: 2^-k <= e^(-254.5 step), k = 46 at 1/8 nat.
constexpr int kExponents = int((double(kLabelCostMax) - 0.5) * double(kLabelCostStep) / 0.6931471805599453) + 2;
constexpr uint32_t kLowestExponent = 127 - (kExponents - 1);
constexpr std::size_t kCostTableSize = std::size_t(kExponents) << kMantissaBits;
static_assert(kLowestExponent >= 1, "the table's ratios must be normal floats");

const std::array<uint8_t, kCostTableSize>& ratio_cost_table() {
  static const std::array<uint8_t, kCostTableSize> table = [] {
    std::array<uint8_t, kCostTableSize> t{};
    for (std::size_t i = 0; i < kCostTableSize; ++i) {
      const int exponent = int(i >> kMantissaBits) - (kExponents - 1);
      const double mantissa = 1.0 + (double(i & ((1u << kMantissaBits) - 1)) + 0.5) / double(1u << kMantissaBits);
      t[i] = cost_from_nats(-(std::log(mantissa) + exponent * std::log(2.0)));
    }
    return t;
  }();
  return table;
}
}  // namespace

void observation_from_probabilities(const float* probs, uint8_t* out) {
  float pmax = 0;
  for (int c = 0; c < kLabelClasses; ++c) pmax = probs[c] > pmax ? probs[c] : pmax;
  out[14] = out[15] = kLabelCostMax;
  if (!(pmax >= FLT_MIN) || !(pmax <= FLT_MAX)) {  // no information: an update that changes nothing
    for (int c = 0; c < kLabelClasses; ++c) out[c] = 0;
    return;
  }
  const std::array<uint8_t, kCostTableSize>& table = ratio_cost_table();
  const float inv_max = 1.0f / pmax;
  for (int c = 0; c < kLabelClasses; ++c) {
    const float r = probs[c] * inv_max;
    uint32_t bits;
    std::memcpy(&bits, &r, sizeof bits);
    // r <= 1 (up to rounding: r == 1 at most), so the index is below the table's end; NaN and
    // negative inputs have bits outside the range and saturate.
    const uint32_t index = (bits >> (23 - kMantissaBits)) - (kLowestExponent << kMantissaBits);
    out[c] = index < kCostTableSize ? table[index] : static_cast<uint8_t>(kLabelCostMax);
  }
}

}  // namespace ef::semantic
