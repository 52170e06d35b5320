// Class-id label images (core/image.h conventions) as PNG: raw ids (8-bit gray, the format
// `edgefusion eval labels` reads) or colourised with the paper's palette (core/classes.h).
#pragma once

#include <string>

#include "core/image.h"
#include "core/result.h"

namespace ef {

// Writes palette colours of `labels` into `out` (same size required; ids above 13 become black).
// Returns false on a size mismatch. Does not allocate.
bool colorize_labels(ImageView<const uint8_t> labels, ImageView<Rgb8> out);

// Colourises into `scratch` (allocated only when its size differs) and writes an RGB PNG.
Status write_label_png_color(const std::string& path, ImageView<const uint8_t> labels, Image<Rgb8>& scratch);
// Convenience without a caller-held scratch image (allocates one per call).
Status write_label_png_color(const std::string& path, ImageView<const uint8_t> labels);

// Writes the raw class ids as an 8-bit gray PNG.
Status write_label_png_ids(const std::string& path, ImageView<const uint8_t> labels);

}  // namespace ef
