// Run-time dispatch of track_rows: the best variant for this CPU (capped by EF_ISA) is chosen on the
// first call and kept in a function-local static (thread-safe initialisation).
#include "kernels/track_rows.h"

#include "kernels/track_rows_variants.h"

namespace ef::kernels {

namespace {
const KernelVariant<TrackRowsFn>& selected() {
  static const KernelVariant<TrackRowsFn>& v = best_variant(kTrackRowsVariants, cpu_features());
  return v;
}
}  // namespace

const char* track_rows_selected() { return selected().name; }

void track_rows(const TrackRowsParams& params, const float* cur_vertex, const float* cur_normal,
                const float* cur_intensity, std::size_t n, float* icp_rows, float* rgb_rows, std::size_t stride,
                TrackRowsCounts* counts) {
  static const TrackRowsFn fn = selected().fn;
  fn(params, cur_vertex, cur_normal, cur_intensity, n, icp_rows, rgb_rows, stride, counts);
}

}  // namespace ef::kernels
