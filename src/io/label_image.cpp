#include "io/label_image.h"

#include "core/classes.h"
#include "io/image_codec.h"

namespace ef {

bool colorize_labels(ImageView<const uint8_t> labels, ImageView<Rgb8> out) {
  if (labels.width != out.width || labels.height != out.height) return false;
  Rgb8 lut[256];
  for (int i = 0; i < 256; ++i) lut[i] = class_color(i);  // ids > 13: black
  for (int y = 0; y < labels.height; ++y) {
    const uint8_t* src = labels.row(y);
    Rgb8* dst = out.row(y);
    for (int x = 0; x < labels.width; ++x) dst[x] = lut[src[x]];
  }
  return true;
}

Status write_label_png_color(const std::string& path, ImageView<const uint8_t> labels, Image<Rgb8>& scratch) {
  if (labels.empty()) return error(ErrorCode::kInvalidArgument, path + ": empty label image");
  scratch.allocate(labels.width, labels.height);
  colorize_labels(labels, scratch.view());
  return write_png(path, scratch.cview());
}

Status write_label_png_color(const std::string& path, ImageView<const uint8_t> labels) {
  Image<Rgb8> scratch;
  return write_label_png_color(path, labels, scratch);
}

Status write_label_png_ids(const std::string& path, ImageView<const uint8_t> labels) {
  if (labels.empty()) return error(ErrorCode::kInvalidArgument, path + ": empty label image");
  return write_png(path, labels);
}

}  // namespace ef
