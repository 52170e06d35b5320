// CDR, the encoding of ROS 2 messages (OMG XCDR1, little-endian), as MCAP's "cdr" message encoding
// uses it: a 4-byte encapsulation header (00 01 00 00: CDR, little-endian), then each field in
// order, a primitive aligned to its own size counted from the end of that header; a string is a
// uint32 length that counts its terminating NUL, the bytes, the NUL; a sequence (T[]) is a uint32
// count and the elements; a fixed array (T[N]) is the elements only; nested messages are inline.
//
// CdrWriter appends to a caller's string (allocation-free once its capacity suffices); CdrReader
// reads one message and fails (ok() false, what() naming the field) on any read past the end.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>

namespace ef::cdr {

class Writer {
 public:
  // Starts a message in `out` (cleared): the encapsulation header.
  explicit Writer(std::string& out) : out_(out) {
    out_.clear();
    out_.append("\x00\x01\x00\x00", 4);
  }
  template <class T>
  void put(T v) {  // a primitive (integer or floating point), aligned
    align(sizeof(T));
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));  // the host is little-endian (checked where messages are written)
    out_.append(b, sizeof(T));
  }
  void string(std::string_view s) {
    put<uint32_t>(static_cast<uint32_t>(s.size() + 1));
    out_.append(s.data(), s.size());
    out_.push_back('\0');
  }
  void bytes(const void* data, std::size_t n) {  // uint8[]
    put<uint32_t>(static_cast<uint32_t>(n));
    out_.append(static_cast<const char*>(data), n);
  }
  // Makes room for a uint8[] of n bytes and returns where they go (the caller fills them).
  char* bytes_in_place(std::size_t n) {
    put<uint32_t>(static_cast<uint32_t>(n));
    out_.resize(out_.size() + n);
    return &out_[out_.size() - n];
  }
  void time(int32_t sec, uint32_t nanosec) {  // builtin_interfaces/Time
    put<int32_t>(sec);
    put<uint32_t>(nanosec);
  }

 private:
  void align(std::size_t a) {
    const std::size_t pos = out_.size() - 4;
    if (pos % a != 0) out_.append(a - pos % a, '\0');
  }
  std::string& out_;
};

class Reader {
 public:
  Reader(const uint8_t* data, std::size_t size) : p_(data), n_(size) {
    if (n_ < 4 || p_[1] != 0x01)
      fail("the encapsulation header (expected little-endian CDR)");
    else
      pos_ = 4;
  }
  bool ok() const { return what_ == nullptr; }
  const char* what() const { return what_ != nullptr ? what_ : ""; }  // the field that did not fit
  template <class T>
  T get(const char* field) {
    T v{};
    if (!align(sizeof(T), field) || !have(sizeof(T), field)) return v;
    std::memcpy(&v, p_ + pos_, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  std::string_view string(const char* field) {
    const uint32_t n = get<uint32_t>(field);
    if (!ok() || n == 0 || !have(n, field)) {
      if (ok() && n == 0) fail(field);
      return {};
    }
    std::string_view s(reinterpret_cast<const char*>(p_ + pos_), n - 1);  // without the NUL
    pos_ += n;
    return s;
  }
  // A uint8[]: pointer into the message and its length.
  const uint8_t* bytes(const char* field, std::size_t& n) {
    n = get<uint32_t>(field);
    if (!ok() || !have(n, field)) {
      n = 0;
      return nullptr;
    }
    const uint8_t* b = p_ + pos_;
    pos_ += n;
    return b;
  }

 private:
  bool have(std::size_t n, const char* field) {
    if (ok() && n <= n_ - pos_) return true;
    fail(field);
    return false;
  }
  bool align(std::size_t a, const char* field) {
    const std::size_t rel = pos_ - 4;
    if (rel % a != 0) {
      if (!have(a - rel % a, field)) return false;
      pos_ += a - rel % a;
    }
    return ok();
  }
  void fail(const char* field) {
    if (what_ == nullptr) what_ = field;
    pos_ = n_;
  }
  const uint8_t* p_;
  std::size_t n_, pos_ = 0;
  const char* what_ = nullptr;
};

}  // namespace ef::cdr
