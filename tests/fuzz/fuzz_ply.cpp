// libFuzzer target for surfel maps as PLY (io/ply_writer.h read_surfel_ply): what `edgefusion view`
// reads for any map it is given (a run's map.ply, or a PLY from another tool), then the picture it
// draws of it (pipeline/map_preview.h: framing by percentiles, the z-buffered splatter, the legend),
// at 64x64 per panel for maps of at most 4096 surfels. Input: the file's bytes, read from an in-memory
// file. Any crash, sanitizer report (a NaN or huge coordinate converted to a pixel index is one) or
// hang is a bug; an error is the expected answer to a bad file.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "fuzz_support.h"
#include "io/ply_writer.h"
#include "pipeline/map_preview.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static ef::fuzz::MemFile file;
  auto cloud = ef::read_surfel_ply(file.write(data, size));
  if (!cloud.ok() || cloud->size() == 0 || cloud->size() > 4096) return 0;
  ef::pipeline::PreviewOptions options;
  options.width = options.height = 64;
  (void)ef::pipeline::render_map_preview(cloud->view(), {}, options);
  options.top = true;
  (void)ef::pipeline::render_map_preview(cloud->view(), {}, options);
  return 0;
}
