// Surfel maps as binary little-endian PLY, readable by Open3D, MeshLab and CloudCompare.
//
// One `vertex` element per surfel, 40 bytes each (35 without classes), properties in this order:
//   float x y z          position, metres, world frame
//   float nx ny nz       unit normal
//   uchar red green blue sRGB colour
//   float radius         surfel radius, metres
//   float confidence     ElasticFusion confidence (accumulated weight)
//   uchar class_id       most probable class (core/classes.h), 0 = unknown   } only for a map with
//   float class_prob     probability of class_id, [0, 1]                     } labels (a class_id column)
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/result.h"

namespace ef {

// A strided read-only column: element i is at (const char*)data + i * stride_bytes.
template <class T>
struct Column {
  const T* data = nullptr;
  std::size_t stride_bytes = sizeof(T);
  Column() = default;
  Column(const T* d, std::size_t stride = sizeof(T)) : data(d), stride_bytes(stride) {}  // NOLINT: implicit
  const T& operator[](std::size_t i) const {
    return *reinterpret_cast<const T*>(reinterpret_cast<const unsigned char*>(data) + i * stride_bytes);
  }
};

// A struct-of-arrays view of `count` surfels; nothing is copied. Interleaved storage works too:
// for `float pos[N][3]` use x = {&pos[0][0], 12}, y = {&pos[0][1], 12}, z = {&pos[0][2], 12}.
// x, y, z are required; a null optional column is written as zeros, except class_id: without it
// neither class property is written (a map without labels has no classes to give).
struct SurfelCloudView {
  std::size_t count = 0;
  Column<float> x, y, z;             // metres
  Column<float> nx, ny, nz;          // unit normal
  Column<uint8_t> red, green, blue;  // sRGB
  Column<float> radius;              // metres
  Column<float> confidence;
  Column<uint8_t> class_id;          // 0..13
  Column<float> class_prob;          // [0, 1]
};

// Bytes per vertex record in the files this writer produces, with and without the class properties.
constexpr std::size_t kPlySurfelRecordBytes = 40;
constexpr std::size_t kPlySurfelRecordBytesWithoutClasses = 35;

// Writes the view to `path` (created or truncated; the parent folder must exist). Streams through
// a fixed 64 KiB buffer. `comment` (optional, single line) is written as a header comment.
Status write_surfel_ply(const std::string& path, const SurfelCloudView& cloud, const std::string& comment = "");

// An owning surfel cloud, as the reader returns it.
struct SurfelCloud {
  std::vector<float> x, y, z, nx, ny, nz, radius, confidence, class_prob;
  std::vector<uint8_t> red, green, blue, class_id;
  bool has_classes = true;  // the file had a class_id property (else class_id and class_prob are zeros)
  std::size_t size() const { return x.size(); }
  // The columns; without classes (has_classes false) no class_id column, as the file was.
  SurfelCloudView view() const;
};

// Reads a binary little-endian PLY whose first element is `vertex` with float x y z and any of the
// properties above (in any order, each of the type written above); other vertex properties of
// the standard scalar types are skipped, missing optional ones read as zeros. Errors name the file
// and the fault: not a PLY, ASCII or big-endian format, unknown type, list properties, a second
// element with a non-zero count, missing x/y/z, a property with an unexpected type, truncated data,
// trailing bytes.
Result<SurfelCloud> read_surfel_ply(const std::string& path);

}  // namespace ef
