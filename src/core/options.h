// Options written once. Each options struct that a user can set (slam::TrackerOptions,
// semantic::DenseCrfOptions, pipeline::PipelineOptions, ...) keeps one table of its user-facing
// fields, a row per field:
//
//   {name, flat, flag, &S::member, unit, range, help}
//
//   name   its key inside its section of the YAML file ("icp_weight" in `mapping:`); the section is
//          given where the table is bound into the run's configuration (pipeline/run_config.cpp)
//   flat   the older top-level key that still works ("crf_iterations"), "" = none
//   flag   the command-line flag of `run` and `plan` ("--crf-iterations"), "" = none. A flag of a
//          bool takes no value and sets the opposite of the field's default ("--no-labels")
//   member a pointer to the field; its default is the struct's own initialiser, written nowhere else
//   unit   numbers: the unit ("metres", "frames"); text: what it names ("folder", "source URI")
//   range  the values allowed (numbers): the one range check, used by parsing and by validate()
//   help   what it does, in a few words
//
// From the rows come: the struct's range checks (check_table, called by its validate()), parsing a
// value of the file or the command line (parse_into), the value as YAML text (value_text), and the
// documentation of the key (describe_row: `edgefusion plan --help`, the README's key list).
#pragma once

#include <cstdint>
#include <limits>
#include <string>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

#include "core/result.h"

namespace ef::opt {

// WIDTHxHEIGHT in pixels (the working resolution).
struct ImageSize {
  int width = 0, height = 0;
};

// The values a number may take: [min, max] (min excluded when min_open), and optionally one more
// value outside it with a meaning of its own (-1 = not pinned, 0 = off).
struct Range {
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  bool min_open = false;
  bool has_special = false;
  double special = 0;
  const char* special_means = "";

  // The special value `v`, meaning `means`, is allowed too.
  constexpr Range or_value(double v, const char* means) const {
    Range r = *this;
    r.has_special = true;
    r.special = v;
    r.special_means = means;
    return r;
  }
  bool contains(double v) const;
  // "1..100", ">= 0", "> 0", "0 (off) or > 1", "-1 (not pinned) or 0..1023"; "" for any value.
  std::string text() const;
};

constexpr Range any() { return Range{}; }
constexpr Range between(double lo, double hi) { return Range{lo, hi, false, false, 0, ""}; }
constexpr Range at_least(double lo) { return Range{lo, std::numeric_limits<double>::infinity(), false, false, 0, ""}; }
constexpr Range above(double lo) { return Range{lo, std::numeric_limits<double>::infinity(), true, false, 0, ""}; }

// The field types options have.
template <class S>
using Member = std::variant<bool S::*, int S::*, int64_t S::*, unsigned S::*, float S::*, double S::*,
                            std::string S::*, ImageSize S::*>;

template <class S>
struct Option {
  const char* name;
  const char* flat;
  const char* flag;
  Member<S> member;
  const char* unit;
  Range range;
  const char* help;
};

template <class S>
using Table = std::vector<Option<S>>;

// ---- Non-template parts (core/options.cpp) ----

// A field's value, type-erased for the functions below.
struct Value {
  enum Kind { kBool, kInt, kReal, kText, kSize } kind = kInt;
  bool b = false;
  int64_t i = 0;
  double d = 0;
  bool single = false;  // kReal: the field is a float (its shortest text is a float's)
  std::string text;
  ImageSize size;
};

// YAML text of a value: true/false, integers in full, reals with up to 9 significant digits
// (whole numbers without an exponent: 10, not 1e+01), text double-quoted with \" and \\ escaped
// when YAML would misread it plain; "" for empty text (an unset path).
std::string yaml_text(const Value& v);
// A YAML double-quoted scalar holding `s` exactly (\" \\ and \xNN escapes).
std::string yaml_quoted(const std::string& s);
// Parses `text` into `v` (whose kind says how) and checks it against `range` (and the integer
// limits `lo`, `hi` of the field's type). Empty on success, else the complaint to follow the
// quoted value: "is not an integer in 1..100", "is not true or false", "is empty (expected a
// folder)", "is not WIDTHxHEIGHT (for example 320x240)".
std::string parse_value(const std::string& text, const Range& range, const char* unit, double lo, double hi,
                        Value& v);
// Empty when `v` is within `range` (and not empty text), else the complaint.
std::string check_value(const Value& v, const Range& range, const char* unit);
// "<help>, <unit>, <range>; default <default>" for a key's documentation.
std::string describe_row(const char* help, const char* unit, const Range& range, const Value& default_value);

// ---- On a struct ----

namespace detail {
template <class T>
constexpr double type_min() {
  if constexpr (std::is_integral_v<T> && !std::is_same_v<T, bool>) return double(std::numeric_limits<T>::min());
  return -std::numeric_limits<double>::infinity();
}
template <class T>
constexpr double type_max() {
  if constexpr (std::is_integral_v<T> && !std::is_same_v<T, bool>) return double(std::numeric_limits<T>::max());
  return std::numeric_limits<double>::infinity();
}
}  // namespace detail

// The field of `s` that `o` names, as a Value.
template <class S>
Value get(const S& s, const Option<S>& o) {
  return std::visit(
      [&](auto member) {
        using T = std::decay_t<decltype(s.*member)>;
        Value v;
        const T& f = s.*member;
        if constexpr (std::is_same_v<T, bool>) {
          v.kind = Value::kBool;
          v.b = f;
        } else if constexpr (std::is_same_v<T, std::string>) {
          v.kind = Value::kText;
          v.text = f;
        } else if constexpr (std::is_same_v<T, ImageSize>) {
          v.kind = Value::kSize;
          v.size = f;
        } else if constexpr (std::is_integral_v<T>) {
          v.kind = Value::kInt;
          v.i = static_cast<int64_t>(f);
        } else {
          v.kind = Value::kReal;
          v.d = static_cast<double>(f);
          v.single = std::is_same_v<T, float>;
        }
        return v;
      },
      o.member);
}

// Sets the field of `s` that `o` names from `v` (of the field's kind; parse_into checked it).
template <class S>
void set(S& s, const Option<S>& o, const Value& v) {
  std::visit(
      [&](auto member) {
        using T = std::decay_t<decltype(s.*member)>;
        T& f = s.*member;
        if constexpr (std::is_same_v<T, bool>) f = v.b;
        else if constexpr (std::is_same_v<T, std::string>) f = v.text;
        else if constexpr (std::is_same_v<T, ImageSize>) f = v.size;
        else if constexpr (std::is_integral_v<T>) f = static_cast<T>(v.i);
        else f = static_cast<T>(v.d);
      },
      o.member);
}

// Parses `text` into the field `o` names. Empty on success (the field is set), else the complaint
// (parse_value's; the field is left as it was).
template <class S>
std::string parse_into(S& s, const Option<S>& o, const std::string& text) {
  Value v = get(s, o);
  const auto limits = std::visit(
      [](auto member) {
        using T = std::decay_t<decltype(S().*member)>;
        return std::pair<double, double>{detail::type_min<T>(), detail::type_max<T>()};
      },
      o.member);
  std::string why = parse_value(text, o.range, o.unit, limits.first, limits.second, v);
  if (why.empty()) set(s, o, v);
  return why;
}

// The field's value as YAML text ("" when it is empty text).
template <class S>
std::string value_text(const S& s, const Option<S>& o) {
  return yaml_text(get(s, o));
}

// Ok when every field of `table` in `s` is within its range; else kInvalidArgument
// "<who>: <name> <value> <complaint>" for the first that is not. Empty text is allowed here (an
// unset path); only parsing refuses an empty value.
template <class S>
Status check_table(const S& s, const Table<S>& table, const char* who) {
  for (const Option<S>& o : table) {
    Value v = get(s, o);
    if (v.kind == Value::kText) continue;
    const std::string why = check_value(v, o.range, o.unit);
    if (!why.empty())
      return error(ErrorCode::kInvalidArgument,
                   std::string(who) + ": " + o.name + " " + yaml_text(v) + " " + why);
  }
  return Status::success();
}

}  // namespace ef::opt
