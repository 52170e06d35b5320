// NumPy .npy files (format version 1.0) of float32 arrays, for `edgefusion segment --probabilities`:
// numpy.load() opens them without any other tool. Layout: the 6-byte magic "\x93NUMPY", version
// bytes 1 0, a little-endian u16 header length, an ASCII dict
// "{'descr': '<f4', 'fortran_order': False, 'shape': (H, W, K), }" padded with spaces and ended by
// '\n' so that the data starts at a multiple of 64 bytes, then the values in C order, little-endian.
#pragma once

#include <cstddef>
#include <string>

#include "core/result.h"

namespace ef::app {

// The header bytes (magic to '\n') for a C-order little-endian float32 array of `dims` dimensions.
std::string npy_header_f32(const std::size_t* shape, int dims);

// Writes `data` (the product of `shape` floats, C order) as `path`. Errors name the file.
Status write_npy_f32(const std::string& path, const float* data, const std::size_t* shape, int dims);

}  // namespace ef::app
