// Small strict parsers for the text files of the dataset formats (TUM lists, pose files,
// intrinsics). Numbers must be complete tokens: "1.5x", "", "nan" and "inf" are rejected.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "core/intrinsics.h"
#include "core/result.h"
#include "io/frame_source.h"

namespace ef::text {

// Parses a whole token as a finite double ("1e-3", "-0.5"). False on anything else.
bool parse_double(std::string_view token, double& out);

// Parses a whole token as a base-10 integer in [min, max]. False on anything else.
bool parse_int(std::string_view token, int64_t min, int64_t max, int64_t& out);

// Splits `line` at spaces, tabs and commas (TUM's tools accept all three); empty fields dropped.
// Appends string_views into `line` to `fields` after clearing it.
void split_fields(std::string_view line, std::vector<std::string_view>& fields);

// Calls fn(line_number (1-based), line) for every line of `text` that is neither blank nor a
// comment ('#' as its first non-blank character). Strips a trailing '\r'. Stops at the first
// non-ok Status and returns it.
template <class Fn>
Status for_each_data_line(std::string_view text, Fn&& fn) {
  std::size_t pos = 0;
  int line_no = 0;
  while (pos < text.size()) {
    std::size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = text.substr(pos, end - pos);
    pos = end + 1;
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    std::size_t first = line.find_first_not_of(" \t");
    if (first == std::string_view::npos || line[first] == '#') continue;
    Status s = fn(line_no, line);
    if (!s.ok()) return s;
  }
  return Status();
}

// Reads a whole (small) text file. Errors: kNotFound when missing, kIoError when unreadable.
// `what` names the file in messages ("groundtruth file '/d/groundtruth.txt'").
Status read_text_file(const std::string& path, std::string& out);

// Shortens a line for quoting in an error message (at most 60 characters, non-printables as '?').
std::string quote_excerpt(std::string_view line);

// Applies the query keys fx, fy, cx, cy of `uri` (pixels; any subset) to `k`. A value that is not
// a finite number, or fx/fy of 0, is a kInvalidArgument error naming the key.
Status apply_intrinsics_overrides(const SourceUri& uri, Intrinsics& k);
// Which of fx, fy, cx, cy the URI's query gives, as "fx, fy, cx, cy" (empty when none).
std::string intrinsics_override_keys(const SourceUri& uri);
// Where a source's intrinsics came from (SourceInfo::intrinsics_from / intrinsics_assumed): `base`
// (the file or the default they started from), then the URI's keys over it; assumed when the base is
// a default and the URI does not give all four.
void describe_intrinsics(const SourceUri& uri, const std::string& base, bool base_is_default, std::string* from,
                         bool* assumed);

}  // namespace ef::text
