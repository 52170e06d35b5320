// The per-surfel label store (issue 6): a distribution over the 14 classes (0 = unknown, 1..13 the
// dataset's classes) in SurfelPool::kLabelBytesPerSurfel = 16 bytes per surfel, held in the pool's
// `labels` column (slam/surfel_pool.h), so it is allocated once with the pool and moves with its
// surfel on every copy, removal and eviction.
//
// Encoding, bytes 0..13: one uint8 "cost" per class, a negative log-probability ratio to the most
// likely class in fixed point:
//   cost_c = min(255, round(-ln(p_c / p_max) / step)),  step = kLabelCostStep = 1/8 nat
// so the most likely class has cost 0, and a class less likely than e^(-255/8) = e^-31.9 ~ 1.4e-14 of
// the best saturates at 255 (it then means "at most 1.4e-14 of the best").
// Bytes 14, 15: reserved, always 0 (the update kernel clears them).
// All-zero = uniform (every class equally likely): what the pool writes for a new surfel.
//
// Precision: a stored cost is exact in the lattice of 1/8 nat; encoding a probability ratio rounds
// the log by at most 1/16 nat, a relative error of at most e^(1/16) - 1 ~ 6.5% on p_c / p_max. The
// Bayesian update (kernels/label_update.h) is exact on costs except for saturation at 255, so after
// k fused observations each class's log-ratio is within k/16 nat of the exact product of the
// (unrounded) CNN probabilities, as long as no cost saturated.
// Why 1/8 nat and not 1/16: saturation forgets evidence. The shipped CNN puts its runner-up class
// a median 8.8 nats below its best (90th percentile 11.5; seed 5001, 230,400 pixels), so with 1/16
// nat (range 15.9 nats) two confident views for another class undid any number of earlier ones.
// Range 31.9 nats raised SF's class average on 6 of 11 held-out sequences by 0.1-0.6 points, left
// 4 the same to one decimal and lowered 1 by 0.1 (the means: +0.2 on seeds 5001-5003 and on the
// five built-in rooms, +0.0 on the robot paths; mIoU +0.2 to +0.3; docs/results.md). The paper's float
// probabilities keep about 87 nats before they underflow to 0, and from 0 they never recover.
//
// Observation vectors (the CNN's side of equation 1) use the same 16-byte layout with the two spare
// bytes set to 255, so they never win the minimum the update takes over a whole vector.
#pragma once

#include <cstddef>
#include <cstdint>

namespace ef::semantic {

inline constexpr int kLabelClasses = 14;               // class 0 unknown .. 13
inline constexpr int kLabelBytes = 16;                 // per surfel and per observation vector
inline constexpr float kLabelCostStep = 1.0f / 8.0f;   // nats per cost unit
inline constexpr int kLabelCostMax = 255;              // saturated: at most e^-31.9 of the best

// Costs -> probabilities (kLabelClasses floats, summing to 1): p_c = e^(-cost_c * step) / Z.
void decode_labels(const uint8_t* costs, float* probs);
// Probabilities (kLabelClasses non-negative floats, not necessarily normalised) -> 16 bytes with
// the reserved bytes 0. A zero probability costs 255; all zero (or non-finite max) gives uniform.
void encode_labels(const float* probs, uint8_t* costs);
// The class with the lowest cost (the most likely), the lowest id on ties.
int label_argmax(const uint8_t* costs);
// The decoded probability of label_argmax(costs).
float label_argmax_probability(const uint8_t* costs);
// label_argmax and label_argmax_probability of `n` consecutive 16-byte stores (a pool's label
// column) into class_id[n] and class_prob[n]: the map.ply class columns. A never-updated (uniform)
// surfel gives class 0 with probability 1/14.
void label_summary(const uint8_t* stores, std::size_t n, uint8_t* class_id, float* class_prob);

// One CNN output pixel -> an observation vector (16 bytes, spare bytes 255):
// cost_c = min(255, round(-ln(p_c / p_max) / step)) by a 94 KiB table on the float bits of
// p_c / p_max (label_store.cpp): it can differ from the exact rounding, by one unit, only where
// -ln(p_c / p_max) / step lies within 0.004 of a half-integer. probs: kLabelClasses floats; a pixel
// whose largest probability is not a normal finite float gives all-zero costs (an update that changes
// nothing). The table is built on the first call (thread-safe, no heap).
void observation_from_probabilities(const float* probs, uint8_t* out);

}  // namespace ef::semantic
