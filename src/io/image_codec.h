// Reading and writing image files with libpng and libjpeg-turbo (Debian's libpng-dev,
// libjpeg62-turbo-dev; both install for arm64 beside amd64, unlike OpenCV's imgcodecs).
//
// Readers fill `out`, reallocating it only when its size differs from the file's, so replaying a
// sequence of same-sized files does not reallocate images. Every error names the file and the fault
// (missing, not a PNG, truncated, wrong bit depth or channel count).
#pragma once

#include <cstdint>
#include <string>

#include "core/image.h"
#include "core/result.h"

namespace ef {

// Colour from PNG (8-bit gray, RGB or RGBA; 16-bit reduced to 8), JPEG, or binary PPM (P6),
// chosen by the file's signature, not its extension.
Status read_color_image(const std::string& path, Image<Rgb8>& out);

// 16-bit single-channel PNG (TUM and 7-Scenes depth). An 8-bit or multi-channel PNG is an error.
Status read_png_u16(const std::string& path, Image<uint16_t>& out);

// 8-bit single-channel PNG (class-id label images). A 16-bit or multi-channel PNG is an error.
Status read_png_u8(const std::string& path, Image<uint8_t>& out);

// Writers: 8-bit RGB, 8-bit gray, 16-bit gray PNG. The parent folder must exist.
Status write_png(const std::string& path, ImageView<const Rgb8> image);
Status write_png(const std::string& path, ImageView<const uint8_t> image);
Status write_png(const std::string& path, ImageView<const uint16_t> image);

// PNG decode in memory (the field log's images): `what` names the image in errors. The readers'
// rules above apply (a wrong bit depth or channel count is an error).
Status decode_png_u16(const uint8_t* bytes, std::size_t size, Image<uint16_t>& out, const std::string& what);
Status decode_png_u8(const uint8_t* bytes, std::size_t size, Image<uint8_t>& out, const std::string& what);
Status decode_png_rgb(const uint8_t* bytes, std::size_t size, Image<Rgb8>& out, const std::string& what);
// JPEG encode/decode in memory (for .klg colour). quality 1..100.
Status encode_jpeg(ImageView<const Rgb8> image, int quality, std::string& out_bytes);
Status decode_jpeg(const uint8_t* bytes, std::size_t size, Image<Rgb8>& out, const std::string& what);

}  // namespace ef
