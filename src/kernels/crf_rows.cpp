// Run-time dispatch of crf_rows: the best variant for this CPU (capped by EF_ISA) is chosen on the
// first call and kept in a function-local static (thread-safe initialisation).
#include "kernels/crf_rows.h"

#include "kernels/crf_rows_variants.h"

namespace ef::kernels {

namespace {
const CrfRowsKernel& selected() {
  static const CrfRowsKernel& k = *best_variant(kCrfRowsVariants, cpu_features()).fn;
  return k;
}
}  // namespace

const char* crf_rows_selected() {
  static const char* name = best_variant(kCrfRowsVariants, cpu_features()).name;
  return name;
}

void crf_slice_rows(const float* rows, const uint32_t* vertices, const uint16_t* weights, std::size_t points,
                    float* out) {
  selected().slice(rows, vertices, weights, points, out);
}

void crf_splat_rows(float* rows, const uint32_t* vertices, const uint16_t* weights, std::size_t points,
                    const float* in) {
  selected().splat(rows, vertices, weights, points, in);
}

void crf_blur_rows(const float* in, float* out, const uint32_t* neighbours, std::size_t begin, std::size_t end) {
  selected().blur(in, out, neighbours, begin, end);
}

}  // namespace ef::kernels
