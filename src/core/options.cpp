#include "core/options.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace ef::opt {

namespace {

// The shortest decimal text that reads back (strtod, then narrowed to float when `single`) as
// exactly `v`; whole numbers in full ("10", "500": the shortest %g would write "1e+01").
std::string number_text(double v, bool single) {
  char buf[40];
  if (v == std::trunc(v) && std::fabs(v) < 1e15) {
    std::snprintf(buf, sizeof buf, "%.0f", v);
    return buf;
  }
  for (int precision = 1; precision <= 17; ++precision) {
    std::snprintf(buf, sizeof buf, "%.*g", precision, v);
    const double back = std::strtod(buf, nullptr);
    if (single ? static_cast<float>(back) == static_cast<float>(v) : back == v) break;
  }
  return buf;
}

std::string bound_text(double v) { return number_text(v, false); }

}  // namespace

std::string yaml_quoted(const std::string& s) {
  std::string q = "\"";
  for (const char ch : s) {
    const auto u = static_cast<unsigned char>(ch);
    if (ch == '"' || ch == '\\') {
      q += '\\';
      q += ch;
    } else if (u < 0x20 || u == 0x7f) {
      char esc[8];
      std::snprintf(esc, sizeof esc, "\\x%02x", u);
      q += esc;
    } else {
      q += ch;
    }
  }
  return q + "\"";
}

namespace {

bool parse_int(const std::string& text, int64_t& out) {
  errno = 0;
  char* end = nullptr;
  const long long v = std::strtoll(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || errno == ERANGE) return false;
  out = v;
  return true;
}

// "an integer in 1..3", "a number >= 0", "a number > 1 or 0 (off)".
std::string expected(const char* kind, const Range& range) {
  const std::string t = range.text();
  if (t.empty()) return kind;
  const bool interval = !t.empty() && t[0] != '>';
  return std::string(kind) + (interval ? " in " : " ") + t;
}

}  // namespace

bool Range::contains(double v) const {
  if (has_special && v == special) return true;
  if (!(min_open ? v > min : v >= min)) return false;
  return v <= max;
}

std::string Range::text() const {
  const bool low = std::isfinite(min), high = std::isfinite(max);
  std::string base;
  if (low && high) base = bound_text(min) + ".." + bound_text(max);
  else if (low) base = std::string(min_open ? "> " : ">= ") + bound_text(min);
  else if (high) base = "<= " + bound_text(max);
  if (!has_special) return base;
  return base + " or " + bound_text(special) + " (" + special_means + ")";
}

std::string yaml_text(const Value& v) {
  switch (v.kind) {
    case Value::kBool:
      return v.b ? "true" : "false";
    case Value::kInt:
      return std::to_string(v.i);
    case Value::kReal:
      return number_text(v.d, v.single);
    case Value::kText:
      return v.text.empty() ? std::string() : yaml_quoted(v.text);
    case Value::kSize:
      return std::to_string(v.size.width) + "x" + std::to_string(v.size.height);
  }
  return {};
}

std::string check_value(const Value& v, const Range& range, const char* unit) {
  switch (v.kind) {
    case Value::kBool:
      return {};
    case Value::kText:
      return v.text.empty() ? "is empty (expected " + std::string(unit) + ")" : std::string();
    case Value::kInt:
      return range.contains(double(v.i)) ? std::string() : "is not " + expected("an integer", range);
    case Value::kReal:
      return std::isfinite(v.d) && range.contains(v.d) ? std::string() : "is not " + expected("a number", range);
    case Value::kSize:
      return range.contains(v.size.width) && range.contains(v.size.height)
                 ? std::string()
                 : "is not WIDTHxHEIGHT with each side in " + range.text() + " pixels (for example 320x240)";
  }
  return {};
}

std::string parse_value(const std::string& text, const Range& range, const char* unit, double lo, double hi,
                        Value& v) {
  switch (v.kind) {
    case Value::kBool:
      if (text == "true" || text == "True" || text == "TRUE" || text == "yes" || text == "on") v.b = true;
      else if (text == "false" || text == "False" || text == "FALSE" || text == "no" || text == "off") v.b = false;
      else return "is not true or false";
      return {};
    case Value::kText:
      v.text = text;
      return check_value(v, range, unit);
    case Value::kInt: {
      int64_t i = 0;
      if (!parse_int(text, i) || double(i) < lo || double(i) > hi) return "is not " + expected("an integer", range);
      v.i = i;
      return check_value(v, range, unit);
    }
    case Value::kReal: {
      errno = 0;
      char* end = nullptr;
      const double d = std::strtod(text.c_str(), &end);
      if (text.empty() || *end != '\0' || errno == ERANGE || !std::isfinite(d)) return "is not " + expected("a number", range);
      v.d = d;
      return check_value(v, range, unit);
    }
    case Value::kSize: {
      const auto x = text.find('x');
      int64_t w = 0, h = 0;
      const std::string bad = "is not WIDTHxHEIGHT with each side in " + range.text() + " pixels (for example 320x240)";
      if (x == std::string::npos || !parse_int(text.substr(0, x), w) || !parse_int(text.substr(x + 1), h)) return bad;
      if (w > 1'000'000 || h > 1'000'000 || w < -1'000'000 || h < -1'000'000) return bad;
      v.size = ImageSize{int(w), int(h)};
      return check_value(v, range, unit);
    }
  }
  return {};
}

std::string describe_row(const char* help, const char* unit, const Range& range, const Value& default_value) {
  std::string s = help;
  const bool number = default_value.kind == Value::kInt || default_value.kind == Value::kReal;
  if (number && unit[0] != '\0') s += ", " + std::string(unit);
  if (number || default_value.kind == Value::kSize) {
    const std::string r = range.text();
    if (!r.empty()) s += ", " + r;
  }
  const std::string d = yaml_text(default_value);
  return s + "; default " + (d.empty() ? "none" : d);
}

}  // namespace ef::opt
