// PNG (libpng), JPEG (libjpeg-turbo) and P6 PPM reading and writing.
//
// Both C libraries report fatal errors through a callback that must not return; we longjmp back
// to a setjmp in the function that owns the library objects. Rules kept below: no C++ object with
// a destructor is created between a setjmp and the calls that may longjmp; library structs are
// destroyed on both paths; the FILE is opened before and closed after the setjmp scope.
#include "io/image_codec.h"

#include <algorithm>
#include <cerrno>
#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <vector>

#include <jpeglib.h>
#include <jerror.h>
#include <png.h>

#include "io/durable_file.h"

namespace ef {

namespace {

// Largest side we accept in any image file (pixels), and largest area: a guard against
// allocations driven by a corrupt header.
constexpr uint32_t kMaxSide = 16384;
constexpr uint64_t kMaxPixels = uint64_t(1) << 26;  // 67 M pixels

bool host_little_endian() {
  const uint16_t one = 1;
  unsigned char b;
  std::memcpy(&b, &one, 1);
  return b == 1;
}

Error file_error(const std::string& path, const std::string& what, ErrorCode code = ErrorCode::kCorruptData) {
  return error(code, "image file '" + path + "': " + what);
}

Error open_error(const std::string& path, int err) {
  return error(err == ENOENT ? ErrorCode::kNotFound : ErrorCode::kIoError,
               "image file '" + path + "': cannot open (" + std::strerror(err) + ")");
}

// RAII for FILE*, used outside the setjmp scopes only.
struct FileCloser {
  std::FILE* f = nullptr;
  ~FileCloser() {
    if (f) std::fclose(f);
  }
};

// ---------------------------------------------------------------------------------------------
// PNG

struct PngErrorState {
  std::jmp_buf jmp;
  char msg[256];
};

[[noreturn]] void png_error_cb(png_structp png, png_const_charp msg) {
  auto* st = static_cast<PngErrorState*>(png_get_error_ptr(png));
  std::snprintf(st->msg, sizeof(st->msg), "%s", msg ? msg : "unknown libpng error");
  std::longjmp(st->jmp, 1);
}

void png_warning_cb(png_structp png, png_const_charp msg) {
  // "Not enough image data" is only a warning in libpng's default (benign) mode; for us a
  // truncated image is an error.
  if (msg && std::strstr(msg, "Not enough image data")) png_error_cb(png, "truncated image data");
}

enum class PngTarget { kRgb8, kGray16, kGray8 };

struct PngOutputs {
  Image<Rgb8>* rgb = nullptr;
  Image<uint16_t>* gray16 = nullptr;
  Image<uint8_t>* gray8 = nullptr;
};

// Reads a PNG whose 8 signature bytes were already consumed from `fp`. On failure returns false
// and leaves a description of the fault in `fault` (what the caller reports after the file name).
bool png_read_stream(std::FILE* fp, PngTarget target, const PngOutputs& outs, char* fault, std::size_t fault_size,
                     bool& format_fault) {
  PngErrorState st;
  st.msg[0] = '\0';
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &st, png_error_cb, png_warning_cb);
  if (!png) {
    std::snprintf(fault, fault_size, "out of memory creating the PNG reader");
    return false;
  }
  png_infop info = png_create_info_struct(png);
  if (!info) {
    png_destroy_read_struct(&png, nullptr, nullptr);
    std::snprintf(fault, fault_size, "out of memory creating the PNG reader");
    return false;
  }
  if (setjmp(st.jmp)) {
    png_destroy_read_struct(&png, &info, nullptr);
    const bool truncated = std::strcmp(st.msg, "Read Error") == 0;
    std::snprintf(fault, fault_size, "%s", truncated ? "truncated (the file ends before the image does)" : st.msg);
    format_fault = false;
    return false;
  }
  png_init_io(png, fp);
  png_set_sig_bytes(png, 8);
  png_set_user_limits(png, kMaxSide, kMaxSide);
  png_read_info(png, info);
  png_uint_32 w = 0, h = 0;
  int bit_depth = 0, color_type = 0, interlace = 0;
  png_get_IHDR(png, info, &w, &h, &bit_depth, &color_type, &interlace, nullptr, nullptr);
  if (static_cast<uint64_t>(w) * h > kMaxPixels) {
    png_destroy_read_struct(&png, &info, nullptr);
    std::snprintf(fault, fault_size, "image of %ux%u pixels is larger than allowed", unsigned(w), unsigned(h));
    return false;
  }
  const char* kind = color_type == PNG_COLOR_TYPE_GRAY         ? "gray"
                     : color_type == PNG_COLOR_TYPE_GRAY_ALPHA ? "gray+alpha"
                     : color_type == PNG_COLOR_TYPE_PALETTE    ? "palette"
                     : color_type == PNG_COLOR_TYPE_RGB        ? "RGB"
                                                               : "RGBA";
  std::size_t pixel_bytes = 0;
  switch (target) {
    case PngTarget::kRgb8:
      if (color_type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
      if (color_type == PNG_COLOR_TYPE_GRAY && bit_depth < 8) png_set_expand_gray_1_2_4_to_8(png);
      if (bit_depth == 16) png_set_strip_16(png);
      if (color_type == PNG_COLOR_TYPE_GRAY || color_type == PNG_COLOR_TYPE_GRAY_ALPHA) png_set_gray_to_rgb(png);
      // Palette expansion also turns a tRNS chunk into alpha: strip it in both cases.
      if ((color_type & PNG_COLOR_MASK_ALPHA) || png_get_valid(png, info, PNG_INFO_tRNS)) png_set_strip_alpha(png);
      pixel_bytes = 3;
      break;
    case PngTarget::kGray16:
      if (bit_depth != 16 || color_type != PNG_COLOR_TYPE_GRAY) {
        png_destroy_read_struct(&png, &info, nullptr);
        std::snprintf(fault, fault_size, "expected a 16-bit single-channel PNG, found %d-bit %s", bit_depth, kind);
        format_fault = true;
        return false;
      }
      if (host_little_endian()) png_set_swap(png);  // PNG samples are big-endian
      pixel_bytes = 2;
      break;
    case PngTarget::kGray8:
      if (bit_depth != 8 || color_type != PNG_COLOR_TYPE_GRAY) {
        png_destroy_read_struct(&png, &info, nullptr);
        std::snprintf(fault, fault_size, "expected an 8-bit single-channel PNG, found %d-bit %s", bit_depth, kind);
        format_fault = true;
        return false;
      }
      pixel_bytes = 1;
      break;
  }
  const int passes = png_set_interlace_handling(png);
  png_read_update_info(png, info);
  if (png_get_rowbytes(png, info) != static_cast<std::size_t>(w) * pixel_bytes) {
    png_destroy_read_struct(&png, &info, nullptr);
    std::snprintf(fault, fault_size, "unexpected row size after conversion");
    return false;
  }
  // Rows go straight into the caller's image (allocated only when its size differs).
  unsigned char* base = nullptr;
  std::size_t stride = static_cast<std::size_t>(w) * pixel_bytes;
  switch (target) {
    case PngTarget::kRgb8:
      outs.rgb->allocate(int(w), int(h));
      base = reinterpret_cast<unsigned char*>(outs.rgb->data());
      break;
    case PngTarget::kGray16:
      outs.gray16->allocate(int(w), int(h));
      base = reinterpret_cast<unsigned char*>(outs.gray16->data());
      break;
    case PngTarget::kGray8:
      outs.gray8->allocate(int(w), int(h));
      base = outs.gray8->data();
      break;
  }
  for (int pass = 0; pass < passes; ++pass)
    for (png_uint_32 y = 0; y < h; ++y) png_read_row(png, base + y * stride, nullptr);
  png_read_end(png, nullptr);
  png_destroy_read_struct(&png, &info, nullptr);
  return true;
}

// ---------------------------------------------------------------------------------------------
// JPEG

struct JpegErrorState {
  jpeg_error_mgr pub;  // must be first: libjpeg hands us a jpeg_error_mgr*
  std::jmp_buf jmp;
  char msg[JMSG_LENGTH_MAX];
};

[[noreturn]] void jpeg_error_exit_cb(j_common_ptr cinfo) {
  auto* st = reinterpret_cast<JpegErrorState*>(cinfo->err);
  (*cinfo->err->format_message)(cinfo, st->msg);
  std::longjmp(st->jmp, 1);
}

void jpeg_emit_message_cb(j_common_ptr cinfo, int level) {
  if (level >= 0) return;  // trace messages
  // Warnings about missing or damaged entropy data mean a truncated or corrupt image: fatal for us.
  const int code = cinfo->err->msg_code;
  if (code == JWRN_JPEG_EOF || code == JWRN_HIT_MARKER || code == JWRN_MUST_RESYNC) jpeg_error_exit_cb(cinfo);
  cinfo->err->num_warnings++;
}

void jpeg_output_message_cb(j_common_ptr) {}

// Decodes from a source already set up by `set_source`. Returns false with `fault` filled.
template <class SetSource>
bool jpeg_decode(SetSource&& set_source, Image<Rgb8>& out, char* fault, std::size_t fault_size) {
  jpeg_decompress_struct cinfo;
  std::memset(&cinfo, 0, sizeof(cinfo));
  JpegErrorState st;
  st.msg[0] = '\0';
  cinfo.err = jpeg_std_error(&st.pub);
  st.pub.error_exit = jpeg_error_exit_cb;
  st.pub.emit_message = jpeg_emit_message_cb;
  st.pub.output_message = jpeg_output_message_cb;
  if (setjmp(st.jmp)) {
    jpeg_destroy_decompress(&cinfo);
    std::snprintf(fault, fault_size, "%s", st.msg);
    return false;
  }
  jpeg_create_decompress(&cinfo);
  set_source(&cinfo);
  jpeg_read_header(&cinfo, TRUE);
  if (cinfo.image_width > kMaxSide || cinfo.image_height > kMaxSide ||
      uint64_t(cinfo.image_width) * cinfo.image_height > kMaxPixels) {
    std::snprintf(fault, fault_size, "JPEG of %ux%u pixels is larger than allowed", unsigned(cinfo.image_width),
                  unsigned(cinfo.image_height));
    jpeg_destroy_decompress(&cinfo);
    return false;
  }
  cinfo.out_color_space = JCS_RGB;
  jpeg_start_decompress(&cinfo);
  if (cinfo.output_components != 3) {
    std::snprintf(fault, fault_size, "JPEG decodes to %d channels, expected 3", cinfo.output_components);
    jpeg_destroy_decompress(&cinfo);
    return false;
  }
  out.allocate(int(cinfo.output_width), int(cinfo.output_height));
  while (cinfo.output_scanline < cinfo.output_height) {
    JSAMPROW row = reinterpret_cast<JSAMPROW>(out.data() + std::size_t(cinfo.output_scanline) * cinfo.output_width);
    jpeg_read_scanlines(&cinfo, &row, 1);
  }
  jpeg_finish_decompress(&cinfo);
  jpeg_destroy_decompress(&cinfo);
  return true;
}

// A JPEG destination that writes into a std::string, growing it by doubling; the string's
// capacity is kept between calls so a writer encoding same-sized frames stops allocating.
struct StringDestination {
  jpeg_destination_mgr pub;  // must be first
  std::string* out;
};

void string_dest_init(j_compress_ptr cinfo) {
  auto* d = reinterpret_cast<StringDestination*>(cinfo->dest);
  d->out->resize(d->out->capacity() < 65536 ? 65536 : d->out->capacity());
  d->pub.next_output_byte = reinterpret_cast<JOCTET*>(&(*d->out)[0]);
  d->pub.free_in_buffer = d->out->size();
}

boolean string_dest_empty(j_compress_ptr cinfo) {
  auto* d = reinterpret_cast<StringDestination*>(cinfo->dest);
  const std::size_t used = d->out->size();
  d->out->resize(used * 2);
  d->pub.next_output_byte = reinterpret_cast<JOCTET*>(&(*d->out)[used]);
  d->pub.free_in_buffer = d->out->size() - used;
  return TRUE;
}

void string_dest_term(j_compress_ptr cinfo) {
  auto* d = reinterpret_cast<StringDestination*>(cinfo->dest);
  d->out->resize(d->out->size() - d->pub.free_in_buffer);
}

// ---------------------------------------------------------------------------------------------
// PPM (binary P6)

// Reads one header token of a PNM file, skipping whitespace and '#' comments.
bool pnm_token(std::FILE* fp, char* buf, std::size_t size) {
  int c = std::fgetc(fp);
  for (;;) {
    while (c == ' ' || c == '\t' || c == '\n' || c == '\r') c = std::fgetc(fp);
    if (c != '#') break;
    while (c != '\n' && c != EOF) c = std::fgetc(fp);
  }
  std::size_t n = 0;
  while (c != EOF && c != ' ' && c != '\t' && c != '\n' && c != '\r' && c != '#') {
    if (n + 1 >= size) return false;
    buf[n++] = static_cast<char>(c);
    c = std::fgetc(fp);
  }
  buf[n] = '\0';
  // The single whitespace after the last header token is consumed here (c), as P6 requires.
  return n > 0;
}

bool pnm_number(std::FILE* fp, unsigned long max, unsigned long& v) {
  char buf[16];
  if (!pnm_token(fp, buf, sizeof(buf))) return false;
  char* end = nullptr;
  if (buf[0] < '0' || buf[0] > '9') return false;
  v = std::strtoul(buf, &end, 10);
  return *end == '\0' && v >= 1 && v <= max;
}

Status read_ppm(std::FILE* fp, const std::string& path, Image<Rgb8>& out) {
  char magic[4];
  if (!pnm_token(fp, magic, sizeof(magic)) || std::strcmp(magic, "P6") != 0)
    return file_error(path, "not a binary PPM (P6)");
  unsigned long w = 0, h = 0, maxval = 0;
  if (!pnm_number(fp, kMaxSide, w) || !pnm_number(fp, kMaxSide, h) || !pnm_number(fp, 65535, maxval))
    return file_error(path, "malformed PPM header (width, height or maxval missing or out of range)");
  if (uint64_t(w) * h > kMaxPixels) return file_error(path, "PPM image is larger than allowed");
  out.allocate(int(w), int(h));
  const std::size_t bytes_per_sample = maxval < 256 ? 1 : 2;
  if (maxval == 255) {
    const std::size_t n = std::size_t(w) * h * 3;
    if (std::fread(out.data(), 1, n, fp) != n) return file_error(path, "truncated PPM pixel data");
    return Status();
  }
  std::vector<unsigned char> row(std::size_t(w) * 3 * bytes_per_sample);
  for (unsigned long y = 0; y < h; ++y) {
    if (std::fread(row.data(), 1, row.size(), fp) != row.size()) return file_error(path, "truncated PPM pixel data");
    Rgb8* dst = out.data() + y * w;
    for (unsigned long x = 0; x < w; ++x) {
      uint8_t c[3];
      for (int k = 0; k < 3; ++k) {
        const std::size_t i = (x * 3 + k) * bytes_per_sample;
        const unsigned long v = bytes_per_sample == 1 ? row[i] : (static_cast<unsigned long>(row[i]) << 8) | row[i + 1];
        c[k] = static_cast<uint8_t>((std::min(v, maxval) * 255 + maxval / 2) / maxval);
      }
      dst[x] = Rgb8{c[0], c[1], c[2]};
    }
  }
  return Status();
}

Status read_png_gray(const std::string& path, PngTarget target, const PngOutputs& outs) {
  FileCloser fc;
  fc.f = std::fopen(path.c_str(), "rb");
  if (!fc.f) return open_error(path, errno);
  unsigned char sig[8];
  const std::size_t got = std::fread(sig, 1, 8, fc.f);
  if (got < 8 || png_sig_cmp(sig, 0, 8) != 0)
    return file_error(path, got == 0 ? "empty file, expected a PNG" : "not a PNG file (bad signature)");
  char fault[300];
  bool format_fault = false;
  if (!png_read_stream(fc.f, target, outs, fault, sizeof(fault), format_fault))
    return file_error(path, fault, format_fault ? ErrorCode::kUnsupported : ErrorCode::kCorruptData);
  return Status();
}

// Writes the PNG into `file`; errors name `path`, the file it becomes.
template <class T>
Status write_png_file(const std::string& file, const std::string& path, ImageView<const T> image, int color_type,
                      int bit_depth) {
  std::FILE* fp = std::fopen(file.c_str(), "wb");
  if (!fp) return open_error(path, errno);
  PngErrorState st;
  st.msg[0] = '\0';
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &st, png_error_cb, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info) {
    png_destroy_write_struct(&png, info ? &info : nullptr);
    std::fclose(fp);
    return file_error(path, "out of memory creating the PNG writer", ErrorCode::kResourceExhausted);
  }
  if (setjmp(st.jmp)) {
    png_destroy_write_struct(&png, &info);
    std::fclose(fp);
    return file_error(path, std::string("PNG write failed: ") + st.msg, ErrorCode::kIoError);
  }
  png_init_io(png, fp);
  png_set_compression_level(png, 3);  // fast; depth PNGs barely shrink at higher levels
  png_set_IHDR(png, info, png_uint_32(image.width), png_uint_32(image.height), bit_depth, color_type,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  if (bit_depth == 16 && host_little_endian()) png_set_swap(png);
  for (int y = 0; y < image.height; ++y) png_write_row(png, reinterpret_cast<png_const_bytep>(image.row(y)));
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  const bool flush_failed = std::fflush(fp) != 0 || std::ferror(fp);
  const bool close_failed = std::fclose(fp) != 0;
  if (flush_failed || close_failed) return file_error(path, "write failed (disk full?)", ErrorCode::kIoError);
  return Status();
}

// Whole or absent: written as <path>.partial and renamed into place (not synced: a frame's image).
template <class T>
Status write_png_impl(const std::string& path, ImageView<const T> image, int color_type, int bit_depth) {
  if (image.empty()) return file_error(path, "cannot write an empty image", ErrorCode::kInvalidArgument);
  FileReplacement replacement(path, Durability::kAtomic);
  EF_RETURN_IF_ERROR(write_png_file(replacement.temp_path(), path, image, color_type, bit_depth));
  return replacement.commit();
}

}  // namespace

Status read_color_image(const std::string& path, Image<Rgb8>& out) {
  FileCloser fc;
  fc.f = std::fopen(path.c_str(), "rb");
  if (!fc.f) return open_error(path, errno);
  unsigned char sig[8] = {0};
  const std::size_t got = std::fread(sig, 1, 8, fc.f);
  if (got == 0) return file_error(path, "empty file");
  char fault[JMSG_LENGTH_MAX + 64];
  if (got == 8 && png_sig_cmp(sig, 0, 8) == 0) {
    PngOutputs outs;
    outs.rgb = &out;
    bool format_fault = false;
    if (!png_read_stream(fc.f, PngTarget::kRgb8, outs, fault, sizeof(fault), format_fault))
      return file_error(path, fault);
    return Status();
  }
  if (got >= 3 && sig[0] == 0xFF && sig[1] == 0xD8 && sig[2] == 0xFF) {
    std::rewind(fc.f);
    std::FILE* fp = fc.f;
    if (!jpeg_decode([fp](j_decompress_ptr c) { jpeg_stdio_src(c, fp); }, out, fault, sizeof(fault)))
      return file_error(path, std::string("JPEG: ") + fault);
    return Status();
  }
  if (got >= 2 && sig[0] == 'P' && sig[1] == '6') {
    std::rewind(fc.f);
    return read_ppm(fc.f, path, out);
  }
  return file_error(path, "unknown image format (expected PNG, JPEG or binary PPM)", ErrorCode::kUnsupported);
}

Status read_png_u16(const std::string& path, Image<uint16_t>& out) {
  PngOutputs outs;
  outs.gray16 = &out;
  return read_png_gray(path, PngTarget::kGray16, outs);
}

Status read_png_u8(const std::string& path, Image<uint8_t>& out) {
  PngOutputs outs;
  outs.gray8 = &out;
  return read_png_gray(path, PngTarget::kGray8, outs);
}

namespace {

// libpng reads through a FILE*: fmemopen gives one over the bytes.
Status decode_png_memory(const uint8_t* bytes, std::size_t size, PngTarget target, const PngOutputs& outs,
                         const std::string& what) {
  if (size < 8 || png_sig_cmp(bytes, 0, 8) != 0) return file_error(what, "not a PNG image (bad signature)");
  FileCloser fc;
  fc.f = ::fmemopen(const_cast<uint8_t*>(bytes), size, "rb");
  if (!fc.f) return file_error(what, "cannot open the PNG bytes for reading", ErrorCode::kResourceExhausted);
  unsigned char sig[8];
  if (std::fread(sig, 1, 8, fc.f) != 8) return file_error(what, "truncated PNG");
  char fault[300];
  bool format_fault = false;
  if (!png_read_stream(fc.f, target, outs, fault, sizeof(fault), format_fault))
    return file_error(what, fault, format_fault ? ErrorCode::kUnsupported : ErrorCode::kCorruptData);
  return Status();
}

}  // namespace

Status decode_png_u16(const uint8_t* bytes, std::size_t size, Image<uint16_t>& out, const std::string& what) {
  PngOutputs outs;
  outs.gray16 = &out;
  return decode_png_memory(bytes, size, PngTarget::kGray16, outs, what);
}

Status decode_png_u8(const uint8_t* bytes, std::size_t size, Image<uint8_t>& out, const std::string& what) {
  PngOutputs outs;
  outs.gray8 = &out;
  return decode_png_memory(bytes, size, PngTarget::kGray8, outs, what);
}

Status decode_png_rgb(const uint8_t* bytes, std::size_t size, Image<Rgb8>& out, const std::string& what) {
  PngOutputs outs;
  outs.rgb = &out;
  return decode_png_memory(bytes, size, PngTarget::kRgb8, outs, what);
}

Status write_png(const std::string& path, ImageView<const Rgb8> image) {
  return write_png_impl(path, image, PNG_COLOR_TYPE_RGB, 8);
}
Status write_png(const std::string& path, ImageView<const uint8_t> image) {
  return write_png_impl(path, image, PNG_COLOR_TYPE_GRAY, 8);
}
Status write_png(const std::string& path, ImageView<const uint16_t> image) {
  return write_png_impl(path, image, PNG_COLOR_TYPE_GRAY, 16);
}

Status encode_jpeg(ImageView<const Rgb8> image, int quality, std::string& out_bytes) {
  if (image.empty()) return error(ErrorCode::kInvalidArgument, "JPEG encode: empty image");
  if (quality < 1 || quality > 100)
    return error(ErrorCode::kInvalidArgument, "JPEG encode: quality " + std::to_string(quality) + " not in 1..100");
  jpeg_compress_struct cinfo;
  std::memset(&cinfo, 0, sizeof(cinfo));
  JpegErrorState st;
  st.msg[0] = '\0';
  cinfo.err = jpeg_std_error(&st.pub);
  st.pub.error_exit = jpeg_error_exit_cb;
  st.pub.output_message = jpeg_output_message_cb;
  StringDestination dest;
  dest.pub.init_destination = string_dest_init;
  dest.pub.empty_output_buffer = string_dest_empty;
  dest.pub.term_destination = string_dest_term;
  dest.out = &out_bytes;
  if (setjmp(st.jmp)) {
    jpeg_destroy_compress(&cinfo);
    out_bytes.clear();
    return error(ErrorCode::kInternal, std::string("JPEG encode failed: ") + st.msg);
  }
  jpeg_create_compress(&cinfo);
  cinfo.dest = &dest.pub;
  cinfo.image_width = JDIMENSION(image.width);
  cinfo.image_height = JDIMENSION(image.height);
  cinfo.input_components = 3;
  cinfo.in_color_space = JCS_RGB;
  jpeg_set_defaults(&cinfo);
  jpeg_set_quality(&cinfo, quality, TRUE);
  jpeg_start_compress(&cinfo, TRUE);
  while (cinfo.next_scanline < cinfo.image_height) {
    JSAMPROW row = reinterpret_cast<JSAMPROW>(const_cast<Rgb8*>(image.row(int(cinfo.next_scanline))));
    jpeg_write_scanlines(&cinfo, &row, 1);
  }
  jpeg_finish_compress(&cinfo);
  jpeg_destroy_compress(&cinfo);
  return Status();
}

Status decode_jpeg(const uint8_t* bytes, std::size_t size, Image<Rgb8>& out, const std::string& what) {
  if (size == 0 || bytes == nullptr) return error(ErrorCode::kCorruptData, what + ": empty JPEG data");
  if (size < 3 || bytes[0] != 0xFF || bytes[1] != 0xD8 || bytes[2] != 0xFF)
    return error(ErrorCode::kCorruptData, what + ": not JPEG data (no start-of-image marker)");
  char fault[JMSG_LENGTH_MAX + 64];
  const auto set_source = [bytes, size](j_decompress_ptr c) {
    jpeg_mem_src(c, const_cast<unsigned char*>(bytes), static_cast<unsigned long>(size));
  };
  if (!jpeg_decode(set_source, out, fault, sizeof(fault)))
    return error(ErrorCode::kCorruptData, what + ": corrupt JPEG (" + fault + ")");
  return Status();
}

}  // namespace ef
