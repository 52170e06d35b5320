// Helpers for the io tests: synthetic frames and byte files.
#pragma once

#include <cmath>
#include <cstdint>
#include <fstream>
#include <initializer_list>
#include <string>

#include <gtest/gtest.h>

#include "core/frame.h"
#include "core/result.h"

namespace ef::test {

// A frame with smooth colour, depth in [0.5, 4) m on a 1 mm grid with some invalid pixels,
// labels 0..13 and a pose.
inline Frame make_frame(int w, int h, int seed, bool labels = true) {
  Frame f;
  f.allocate(w, h, labels);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      f.color(x, y) = Rgb8{uint8_t(x * 4 + seed), uint8_t(y * 4), uint8_t((x + y + seed * 7) & 255)};
      const int mm = 500 + ((x * 37 + y * 91 + seed * 13) % 3500);
      f.depth(x, y) = ((x + y + seed) % 11 == 0) ? 0.0f : float(mm) * 0.001f;
      if (labels) f.labels(x, y) = uint8_t((x / 4 + y / 4 + seed) % 14);
    }
  f.timestamp = 1305031102.175304 + seed * 0.0333;
  f.index = seed;
  f.has_pose = true;
  Vector6d xi;
  xi << 0.1 * seed, -0.2, 0.3 + 0.01 * seed, 0.05 * seed, 0.1, -0.3;
  f.T_wc = SE3::exp(xi);
  f.has_labels = labels;
  f.name = "f" + std::to_string(seed);
  return f;
}

inline void write_bytes(const std::string& path, const std::string& bytes) {
  std::ofstream f(path, std::ios::binary);
  f.write(bytes.data(), std::streamsize(bytes.size()));
}

inline std::string read_bytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

// Asserts an error with `code` whose message contains every one of `parts`.
#define EXPECT_ERROR_WITH(expr, code_, ...)                                               \
  do {                                                                                     \
    auto ef_r_ = (expr);                                                                   \
    ASSERT_FALSE(ef_r_.ok()) << "expected an error from " #expr;                           \
    EXPECT_EQ(ef_r_.error().code, code_) << ef_r_.error().message;                         \
    for (const std::string& ef_p_ : std::initializer_list<std::string>{__VA_ARGS__})                                     \
      EXPECT_NE(ef_r_.error().message.find(ef_p_), std::string::npos)                      \
          << "message '" << ef_r_.error().message << "' lacks '" << ef_p_ << "'";          \
  } while (0)

}  // namespace ef::test
