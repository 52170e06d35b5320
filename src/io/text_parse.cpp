#include "io/text_parse.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>

namespace ef::text {

bool parse_double(std::string_view token, double& out) {
  // strtod needs a terminated string; tokens in our formats are short, longer ones are garbage.
  char buf[128];
  if (token.empty() || token.size() >= sizeof(buf)) return false;
  std::memcpy(buf, token.data(), token.size());
  buf[token.size()] = '\0';
  // Only plain decimal notation: reject hex floats, "inf", "nan" and leading spaces up front.
  for (char c : token) {
    if (!((c >= '0' && c <= '9') || c == '.' || c == '-' || c == '+' || c == 'e' || c == 'E')) return false;
  }
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(buf, &end);
  if (end != buf + token.size() || errno == ERANGE || !std::isfinite(v)) return false;
  out = v;
  return true;
}

bool parse_int(std::string_view token, int64_t min, int64_t max, int64_t& out) {
  if (token.empty() || token.size() > 20) return false;
  std::size_t i = 0;
  bool negative = false;
  if (token[0] == '-' || token[0] == '+') {
    negative = token[0] == '-';
    i = 1;
    if (token.size() == 1) return false;
  }
  // Accumulate as a negative number so INT64_MIN fits.
  int64_t v = 0;
  for (; i < token.size(); ++i) {
    const char c = token[i];
    if (c < '0' || c > '9') return false;
    const int d = c - '0';
    if (v < (std::numeric_limits<int64_t>::min() + d) / 10) return false;
    v = v * 10 - d;
  }
  if (!negative) {
    if (v == std::numeric_limits<int64_t>::min()) return false;
    v = -v;
  }
  if (v < min || v > max) return false;
  out = v;
  return true;
}

void split_fields(std::string_view line, std::vector<std::string_view>& fields) {
  fields.clear();
  std::size_t i = 0;
  const auto is_sep = [](char c) { return c == ' ' || c == '\t' || c == ',' || c == '\r'; };
  while (i < line.size()) {
    while (i < line.size() && is_sep(line[i])) ++i;
    std::size_t start = i;
    while (i < line.size() && !is_sep(line[i])) ++i;
    if (i > start) fields.push_back(line.substr(start, i - start));
  }
}

Status read_text_file(const std::string& path, std::string& out) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) {
    const int err = errno;
    return error(err == ENOENT ? ErrorCode::kNotFound : ErrorCode::kIoError,
                 "'" + path + "': cannot open (" + std::strerror(err) + ")");
  }
  out.clear();
  char buf[65536];
  std::size_t n;
  while ((n = std::fread(buf, 1, sizeof(buf), f)) > 0) out.append(buf, n);
  const bool failed = std::ferror(f) != 0;
  std::fclose(f);
  if (failed) return error(ErrorCode::kIoError, "'" + path + "': read error");
  return Status();
}

std::string quote_excerpt(std::string_view line) {
  std::string s;
  const std::size_t n = line.size() < 60 ? line.size() : 60;
  for (std::size_t i = 0; i < n; ++i) {
    const unsigned char c = static_cast<unsigned char>(line[i]);
    s.push_back(c >= 32 && c < 127 ? static_cast<char>(c) : '?');
  }
  if (line.size() > 60) s += "...";
  return "'" + s + "'";
}

std::string intrinsics_override_keys(const SourceUri& uri) {
  std::string keys;
  for (const char* key : {"fx", "fy", "cx", "cy"})
    if (uri.query.count(key) != 0) keys += (keys.empty() ? "" : ", ") + std::string(key);
  return keys;
}

void describe_intrinsics(const SourceUri& uri, const std::string& base, bool base_is_default, std::string* from,
                         bool* assumed) {
  const std::string keys = intrinsics_override_keys(uri);
  const bool all = keys == "fx, fy, cx, cy";
  *from = all ? "the URI's fx, fy, cx, cy" : keys.empty() ? base : base + ", the URI's " + keys;
  *assumed = base_is_default && !all;
}

Status apply_intrinsics_overrides(const SourceUri& uri, Intrinsics& k) {
  const char* keys[4] = {"fx", "fy", "cx", "cy"};
  float* dst[4] = {&k.fx, &k.fy, &k.cx, &k.cy};
  for (int i = 0; i < 4; ++i) {
    auto it = uri.query.find(keys[i]);
    if (it == uri.query.end()) continue;
    double v = 0;
    if (!parse_double(it->second, v) || (i < 2 && v == 0))
      return error(ErrorCode::kInvalidArgument, "source '" + uri.scheme + ":" + uri.path + "': option " + keys[i] +
                                                    "=" + it->second + " is not a valid number of pixels");
    *dst[i] = static_cast<float>(v);
  }
  return Status();
}

}  // namespace ef::text
