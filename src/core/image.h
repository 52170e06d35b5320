// Images: a non-owning strided view and an owning buffer allocated once.
//
// Conventions used across EdgeFusion:
//   colour   Image<Rgb8>      8-bit sRGB, R G B byte order
//   depth    Image<float>     metres along the optical axis, 0 = invalid
//   labels   Image<uint8_t>   class id, 0 = unknown, 1..13 the NYUv2 13 classes (see core/classes.h)
// Pixel (x, y) has its centre at (x, y): x to the right, y down, origin at the top-left pixel centre.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <type_traits>
#include <utility>

namespace ef {

struct Rgb8 {
  uint8_t r, g, b;
  friend bool operator==(const Rgb8& a, const Rgb8& b) { return a.r == b.r && a.g == b.g && a.b == b.b; }
  friend bool operator!=(const Rgb8& a, const Rgb8& b) { return !(a == b); }
};
static_assert(sizeof(Rgb8) == 3, "Rgb8 must be packed");

// A borrowed view of pixels. stride_bytes may exceed width * sizeof(T) (padding, sub-images).
template <class T>
struct ImageView {
  T* data = nullptr;
  int width = 0;
  int height = 0;
  std::size_t stride_bytes = 0;

  ImageView() = default;
  ImageView(T* d, int w, int h, std::size_t stride) : data(d), width(w), height(h), stride_bytes(stride) {}
  ImageView(T* d, int w, int h) : ImageView(d, w, h, static_cast<std::size_t>(w) * sizeof(T)) {}
  // A view of non-const pixels converts to a view of const pixels.
  template <class U, class = std::enable_if_t<std::is_same_v<const U, T>>>
  ImageView(const ImageView<U>& o) : data(o.data), width(o.width), height(o.height), stride_bytes(o.stride_bytes) {}  // NOLINT

  bool empty() const { return data == nullptr || width <= 0 || height <= 0; }
  bool contiguous() const { return stride_bytes == static_cast<std::size_t>(width) * sizeof(T); }
  bool in_bounds(int x, int y) const { return x >= 0 && y >= 0 && x < width && y < height; }

  T* row(int y) const {
    using Byte = std::conditional_t<std::is_const_v<T>, const unsigned char, unsigned char>;
    return reinterpret_cast<T*>(reinterpret_cast<Byte*>(data) + static_cast<std::size_t>(y) * stride_bytes);
  }
  T& operator()(int x, int y) const { return row(y)[x]; }

  // The sub-rectangle [x0, x0+w) x [y0, y0+h); no bounds check beyond debug asserts by the caller.
  ImageView sub(int x0, int y0, int w, int h) const { return ImageView(row(y0) + x0, w, h, stride_bytes); }
};

// Owning image, tightly packed. Allocates only in the constructor or in allocate(); assigning a
// view of the same size copies pixels without allocating.
template <class T>
class Image {
 public:
  Image() = default;
  Image(int width, int height) { allocate(width, height); }
  // A moved-from image is empty (0 x 0), not a size without pixels.
  Image(Image&& o) noexcept
      : pixels_(std::move(o.pixels_)), width_(std::exchange(o.width_, 0)), height_(std::exchange(o.height_, 0)) {}
  Image& operator=(Image&& o) noexcept {
    if (this != &o) {
      pixels_ = std::move(o.pixels_);
      width_ = std::exchange(o.width_, 0);
      height_ = std::exchange(o.height_, 0);
    }
    return *this;
  }
  Image(const Image& o) : Image(o.width_, o.height_) { copy_from(o.view()); }
  Image& operator=(const Image& o) {
    if (this != &o) {
      if (o.width_ != width_ || o.height_ != height_) allocate(o.width_, o.height_);
      copy_from(o.view());
    }
    return *this;
  }

  // (Re)allocates to width x height, zero-filled. Does nothing if the size is already right
  // (the pixels are then left as they are). A non-positive width or height gives an empty 0 x 0 image.
  void allocate(int width, int height) {
    if (width <= 0 || height <= 0) width = height = 0;
    if (width == width_ && height == height_ && pixels_) return;
    width_ = width;
    height_ = height;
    pixels_.reset(width > 0 && height > 0 ? new T[static_cast<std::size_t>(width) * height]() : nullptr);
  }

  int width() const { return width_; }
  int height() const { return height_; }
  bool empty() const { return pixels_ == nullptr; }
  std::size_t size() const { return static_cast<std::size_t>(width_) * height_; }
  std::size_t stride_bytes() const { return static_cast<std::size_t>(width_) * sizeof(T); }
  T* data() { return pixels_.get(); }
  const T* data() const { return pixels_.get(); }
  T& operator()(int x, int y) { return pixels_[static_cast<std::size_t>(y) * width_ + x]; }
  const T& operator()(int x, int y) const { return pixels_[static_cast<std::size_t>(y) * width_ + x]; }

  ImageView<T> view() { return ImageView<T>(pixels_.get(), width_, height_); }
  ImageView<const T> view() const { return ImageView<const T>(pixels_.get(), width_, height_); }
  ImageView<const T> cview() const { return view(); }

  void fill(const T& value) {
    for (std::size_t i = 0; i < size(); ++i) pixels_[i] = value;
  }

  // Copies pixels from a view of the same size. Returns false (and copies nothing) on a size mismatch.
  bool copy_from(ImageView<const T> src) {
    if (src.width != width_ || src.height != height_) return false;
    for (int y = 0; y < height_; ++y)
      std::memcpy(pixels_.get() + static_cast<std::size_t>(y) * width_, src.row(y), stride_bytes());
    return true;
  }

 private:
  std::unique_ptr<T[]> pixels_;
  int width_ = 0;
  int height_ = 0;
};

}  // namespace ef
