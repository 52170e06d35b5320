#include "npy_writer.h"

#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>

#include "io/durable_file.h"

namespace ef::app {

// '<f4' promises little-endian values, and they are written as they lie in memory.
static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "npy_writer writes floats in host order as '<f4'");

namespace {
constexpr std::size_t kPreambleBytes = 10;  // magic (6), version (2), header length (2)
constexpr std::size_t kAlign = 64;          // numpy >= 1.14 aligns the data to 64 bytes
}  // namespace

std::string npy_header_f32(const std::size_t* shape, int dims) {
  std::string dict = "{'descr': '<f4', 'fortran_order': False, 'shape': (";
  for (int i = 0; i < dims; ++i) {
    dict += std::to_string(shape[i]);
    // A 1-tuple needs its trailing comma in Python: (5,).
    if (i + 1 < dims || dims == 1) dict += ",";
    if (i + 1 < dims) dict += " ";
  }
  dict += "), }";
  // Pad with spaces so that preamble + dict + '\n' is a multiple of 64.
  const std::size_t unpadded = kPreambleBytes + dict.size() + 1;
  dict.append((kAlign - unpadded % kAlign) % kAlign, ' ');
  dict += '\n';
  const std::size_t header_len = dict.size();  // < 65536: a few dimensions only
  std::string out("\x93NUMPY\x01\x00", 8);
  out += static_cast<char>(header_len & 0xff);
  out += static_cast<char>((header_len >> 8) & 0xff);
  out += dict;
  return out;
}

Status write_npy_f32(const std::string& path, const float* data, const std::size_t* shape, int dims) {
  std::size_t count = 1;
  for (int i = 0; i < dims; ++i) count *= shape[i];
  const std::string header = npy_header_f32(shape, dims);
  return write_file_whole(path, {{header.data(), header.size()}, {data, count * sizeof(float)}});  // whole or absent
}

}  // namespace ef::app
