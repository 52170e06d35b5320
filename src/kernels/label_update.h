// The Bayesian label update of SemanticFusion (McCormac et al., ICRA 2017, equation 1) on the label
// store's fixed-point costs (semantic/label_store.h documents the encoding):
//   P(l | I_1..k) = (1/Z) P(l | I_1..k-1) P(O_k = l | I_k)
// In costs (cost_c = round(-ln(p_c / p_max) / step), step 1/8 nat) the product is an addition and the
// normalisation 1/Z is the subtraction of the smallest cost, so the most likely class is 0 again:
//   t_c = min(255, old_c + obs_c)   for the 16 bytes
//   m   = min over the 14 class bytes of t
//   new_c = t_c - m (classes 0..13), new_14 = new_15 = 0 (the reserved bytes)
// Observation vectors carry 255 in their two spare bytes, so a min over all 16 bytes equals the min
// over the 14 classes. Integer arithmetic only: every variant writes the reference's bytes.
#pragma once

#include <cstddef>
#include <cstdint>

namespace ef::kernels {

inline constexpr int kLabelUpdateBytes = 16;  // bytes per surfel and per observation vector
inline constexpr int kLabelUpdateClasses = 14;

// One update: the surfel's 16 bytes at store + 16 * surfel, the observation's at obs + 16 * observation.
struct LabelUpdatePair {
  int32_t surfel;
  int32_t observation;
};

// Applies every pair in order (a surfel may appear more than once: the updates then compose).
// Dispatched to the best variant for this CPU (platform/cpu_features, EF_ISA caps it).
void label_update(uint8_t* store, const uint8_t* obs, const LabelUpdatePair* pairs, std::size_t n);

// Name of the variant label_update() dispatches to on this CPU.
const char* label_update_selected();

// Merges one stored distribution into another, for two surfels found to be the same surface: the
// product of the two (each holds independent evidence), renormalised, in place in `keep`:
//   keep_c = min(255, keep_c + other_c) - min over c of that   (classes 0..13; bytes 14, 15 = 0)
// Both arguments are 16-byte store vectors (reserved bytes 0). Scalar: merges are a few per frame.
void label_merge(uint8_t* keep, const uint8_t* other);

}  // namespace ef::kernels
