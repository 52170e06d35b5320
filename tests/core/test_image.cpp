#include <gtest/gtest.h>

#include <cstdint>
#include <type_traits>
#include <vector>

#include "core/image.h"

namespace ef {
namespace {

// A 5x3 view into a buffer with rows of 8 floats (3 floats of padding per row).
struct PaddedBuffer {
  static constexpr int kW = 5, kH = 3, kRow = 8;
  std::vector<float> storage = std::vector<float>(kRow * kH, -1.0f);
  PaddedBuffer() {
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x) storage[y * kRow + x] = static_cast<float>(10 * y + x);
  }
  ImageView<float> view() { return ImageView<float>(storage.data(), kW, kH, kRow * sizeof(float)); }
};

TEST(ImageView, StrideAddressesRows) {
  PaddedBuffer buf;
  ImageView<float> v = buf.view();
  EXPECT_FALSE(v.contiguous());
  EXPECT_FALSE(v.empty());
  for (int y = 0; y < v.height; ++y) {
    EXPECT_EQ(v.row(y), buf.storage.data() + y * PaddedBuffer::kRow);
    for (int x = 0; x < v.width; ++x) EXPECT_EQ(v(x, y), static_cast<float>(10 * y + x));
  }
  v(4, 2) = 99.0f;
  EXPECT_EQ(buf.storage[2 * PaddedBuffer::kRow + 4], 99.0f);

  std::vector<uint8_t> packed(6 * 4);
  ImageView<uint8_t> p(packed.data(), 6, 4);
  EXPECT_TRUE(p.contiguous());
  EXPECT_EQ(p.stride_bytes, 6u);
}

TEST(ImageView, StrideOfThreeByteRgbPixels) {
  // Stride in bytes need not be a multiple of sizeof(T) when T is Rgb8 packed in odd-sized rows.
  std::vector<uint8_t> bytes(7 * 2, 0);
  ImageView<Rgb8> v(reinterpret_cast<Rgb8*>(bytes.data()), 2, 2, 7);
  v(1, 1) = Rgb8{1, 2, 3};
  EXPECT_EQ(bytes[7 + 3], 1);
  EXPECT_EQ(bytes[7 + 4], 2);
  EXPECT_EQ(bytes[7 + 5], 3);
}

TEST(ImageView, SubViewSharesPixelsAndStride) {
  PaddedBuffer buf;
  ImageView<float> v = buf.view();
  ImageView<float> s = v.sub(1, 1, 3, 2);
  EXPECT_EQ(s.width, 3);
  EXPECT_EQ(s.height, 2);
  EXPECT_EQ(s.stride_bytes, v.stride_bytes);
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 3; ++x) EXPECT_EQ(s(x, y), v(x + 1, y + 1));
  s(0, 0) = -7.0f;
  EXPECT_EQ(v(1, 1), -7.0f);
  // A sub-view of a sub-view.
  ImageView<float> ss = s.sub(2, 1, 1, 1);
  EXPECT_EQ(&ss(0, 0), &v(3, 2));
  EXPECT_TRUE(s.in_bounds(2, 1));
  EXPECT_FALSE(s.in_bounds(3, 0));
  EXPECT_FALSE(s.in_bounds(0, -1));
}

TEST(ImageView, ConvertsToConstButNotBack) {
  static_assert(std::is_convertible_v<ImageView<float>, ImageView<const float>>);
  static_assert(!std::is_convertible_v<ImageView<const float>, ImageView<float>>);
  static_assert(!std::is_convertible_v<ImageView<float>, ImageView<const double>>);
  PaddedBuffer buf;
  ImageView<float> v = buf.view();
  ImageView<const float> c = v;
  EXPECT_EQ(c.data, v.data);
  EXPECT_EQ(c.width, v.width);
  EXPECT_EQ(c.height, v.height);
  EXPECT_EQ(c.stride_bytes, v.stride_bytes);
  EXPECT_EQ(c(2, 1), 12.0f);
  ImageView<const float> cs = c.sub(1, 1, 2, 2);
  EXPECT_EQ(cs(1, 1), 22.0f);
}

TEST(ImageView, EmptyViews) {
  EXPECT_TRUE(ImageView<float>().empty());
  float px = 0;
  EXPECT_TRUE(ImageView<float>(&px, 0, 3).empty());
  EXPECT_TRUE(ImageView<float>(&px, 3, 0).empty());
  EXPECT_FALSE(ImageView<float>(&px, 1, 1).empty());
}

TEST(Image, AllocateZeroFillsAndKeepsPointerOnSameSize) {
  Image<float> im(4, 3);
  ASSERT_FALSE(im.empty());
  EXPECT_EQ(im.size(), 12u);
  EXPECT_EQ(im.stride_bytes(), 4 * sizeof(float));
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 4; ++x) EXPECT_EQ(im(x, y), 0.0f);
  im(3, 2) = 5.0f;
  const float* before = im.data();
  im.allocate(4, 3);
  EXPECT_EQ(im.data(), before);
  EXPECT_EQ(im(3, 2), 5.0f) << "same-size allocate must leave the pixels alone";
  im.allocate(3, 4);  // same pixel count, different shape: a new zeroed image
  EXPECT_EQ(im.width(), 3);
  EXPECT_EQ(im.height(), 4);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 3; ++x) EXPECT_EQ(im(x, y), 0.0f);
}

TEST(Image, ViewIsContiguousAndAliasesPixels) {
  Image<uint8_t> im(5, 2);
  ImageView<uint8_t> v = im.view();
  EXPECT_TRUE(v.contiguous());
  EXPECT_EQ(v.data, im.data());
  v(4, 1) = 42;
  EXPECT_EQ(im(4, 1), 42);
  const Image<uint8_t>& cim = im;
  ImageView<const uint8_t> cv = cim.view();
  EXPECT_EQ(cv(4, 1), 42);
  EXPECT_EQ(im.cview().data, im.data());
}

TEST(Image, CopyFromStridedViewAndSizeMismatch) {
  PaddedBuffer buf;
  Image<float> im(PaddedBuffer::kW, PaddedBuffer::kH);
  im.fill(3.0f);
  const float* before = im.data();
  ASSERT_TRUE(im.copy_from(buf.view()));
  EXPECT_EQ(im.data(), before);
  for (int y = 0; y < PaddedBuffer::kH; ++y)
    for (int x = 0; x < PaddedBuffer::kW; ++x) EXPECT_EQ(im(x, y), static_cast<float>(10 * y + x));

  // A sub-view copies only its rectangle.
  Image<float> small(2, 2);
  ASSERT_TRUE(small.copy_from(buf.view().sub(3, 1, 2, 2)));
  EXPECT_EQ(small(0, 0), 13.0f);
  EXPECT_EQ(small(1, 1), 24.0f);

  // Size mismatch (either dimension): false, nothing copied, nothing reallocated.
  im.fill(7.0f);
  EXPECT_FALSE(im.copy_from(buf.view().sub(0, 0, 4, 3)));
  EXPECT_FALSE(im.copy_from(buf.view().sub(0, 0, 5, 2)));
  EXPECT_EQ(im.data(), before);
  EXPECT_EQ(im.width(), PaddedBuffer::kW);
  for (int y = 0; y < PaddedBuffer::kH; ++y)
    for (int x = 0; x < PaddedBuffer::kW; ++x) EXPECT_EQ(im(x, y), 7.0f);
}

TEST(Image, CopyIsDeepAndSameSizeAssignmentKeepsBuffer) {
  Image<Rgb8> a(3, 2);
  a.fill(Rgb8{1, 2, 3});
  Image<Rgb8> b(a);
  EXPECT_NE(b.data(), a.data());
  EXPECT_EQ(b(2, 1), (Rgb8{1, 2, 3}));
  b(0, 0) = Rgb8{9, 9, 9};
  EXPECT_EQ(a(0, 0), (Rgb8{1, 2, 3}));

  Image<Rgb8> c(3, 2);
  const Rgb8* c_before = c.data();
  c = b;
  EXPECT_EQ(c.data(), c_before);
  EXPECT_EQ(c(0, 0), (Rgb8{9, 9, 9}));

  Image<Rgb8> d(1, 1);
  d = a;  // different size: reallocates
  EXPECT_EQ(d.width(), 3);
  EXPECT_EQ(d.height(), 2);
  EXPECT_EQ(d(1, 1), (Rgb8{1, 2, 3}));

  const Image<Rgb8>& same = c;  // (a reference: clang warns on a literal `c = c`)
  c = same;  // self-assignment is a no-op
  EXPECT_EQ(c(0, 0), (Rgb8{9, 9, 9}));
}

TEST(Image, MovedFromImageIsEmptyAndReusable) {
  Image<float> a(4, 4);
  a.fill(1.0f);
  const float* pixels = a.data();
  Image<float> b(std::move(a));
  EXPECT_EQ(b.data(), pixels);
  EXPECT_EQ(b.width(), 4);
  // The moved-from image must be consistently empty: a size that claims 4x4 with no pixels makes
  // copy_from/operator= write through a null pointer.
  EXPECT_TRUE(a.empty());      // NOLINT(bugprone-use-after-move): testing the moved-from state
  ASSERT_EQ(a.size(), 0u);
  EXPECT_EQ(a.width(), 0);
  EXPECT_EQ(a.height(), 0);
  a = b;
  ASSERT_FALSE(a.empty());
  EXPECT_EQ(a(3, 3), 1.0f);
  EXPECT_NE(a.data(), b.data());

  Image<float> c(2, 2);
  c = std::move(b);
  EXPECT_EQ(c.data(), pixels);
  EXPECT_TRUE(b.empty());  // NOLINT(bugprone-use-after-move)
  ASSERT_EQ(b.size(), 0u);
  EXPECT_FALSE(b.copy_from(c.view()));  // 0x0 vs 4x4: a size mismatch, not a write through null
}

TEST(Image, NonPositiveSizeIsEmpty) {
  Image<float> im;
  EXPECT_TRUE(im.empty());
  EXPECT_EQ(im.size(), 0u);
  im.allocate(-3, 5);
  EXPECT_TRUE(im.empty());
  ASSERT_EQ(im.size(), 0u);
  im.fill(1.0f);  // no pixels: must not write anywhere
  im.allocate(0, 7);
  EXPECT_TRUE(im.empty());
  EXPECT_EQ(im.size(), 0u);
}

}  // namespace
}  // namespace ef
