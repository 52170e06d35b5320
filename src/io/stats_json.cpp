#include "io/stats_json.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "io/durable_file.h"

namespace ef {

void JsonWriter::append_escaped(std::string& out, std::string_view s) {
  out += '"';
  for (const char ch : s) {
    const unsigned char c = static_cast<unsigned char>(ch);
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\r': out += "\\r"; break;
      case '\t': out += "\\t"; break;
      case '\b': out += "\\b"; break;
      case '\f': out += "\\f"; break;
      default:
        if (c < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof buf, "\\u%04x", c);
          out += buf;
        } else {
          out += ch;
        }
    }
  }
  out += '"';
}

void JsonWriter::before_value() {
  if (after_key_) {
    after_key_ = false;
    return;
  }
  if (!first_.empty()) {
    if (!first_.back()) out_ += ',';
    first_.back() = false;
  }
}

void JsonWriter::begin_object() {
  before_value();
  out_ += '{';
  first_.push_back(true);
}

void JsonWriter::end_object() {
  out_ += '}';
  if (!first_.empty()) first_.pop_back();
}

void JsonWriter::key(std::string_view k) {
  if (!first_.empty()) {
    if (!first_.back()) out_ += ',';
    first_.back() = false;
  }
  append_escaped(out_, k);
  out_ += ':';
  after_key_ = true;
}

void JsonWriter::value(double v) {
  before_value();
  if (!std::isfinite(v)) {
    out_ += "null";
    return;
  }
  char buf[32];
  // The shortest of %.15g / %.16g / %.17g that reads back to the same double.
  for (int prec = 15; prec <= 17; ++prec) {
    std::snprintf(buf, sizeof buf, "%.*g", prec, v);
    if (std::strtod(buf, nullptr) == v) break;
  }
  out_ += buf;
}

void JsonWriter::value(int64_t v) {
  before_value();
  char buf[24];
  std::snprintf(buf, sizeof buf, "%lld", static_cast<long long>(v));
  out_ += buf;
}

void JsonWriter::value(uint64_t v) {
  before_value();
  char buf[24];
  std::snprintf(buf, sizeof buf, "%llu", static_cast<unsigned long long>(v));
  out_ += buf;
}

void JsonWriter::clear() {
  out_.clear();
  first_.clear();
  after_key_ = false;
}

void JsonWriter::reserve(std::size_t bytes, std::size_t depth) {
  out_.reserve(bytes);
  first_.reserve(depth);
}

void JsonWriter::value(std::string_view s) {
  before_value();
  append_escaped(out_, s);
}

void JsonWriter::value_null() {
  before_value();
  out_ += "null";
}

void JsonWriter::value_bool(bool b) {
  before_value();
  out_ += b ? "true" : "false";
}

void write_stats_object(JsonWriter& w, const StageStats& stats, uint64_t frames, double seconds,
                        const std::vector<StatsExtraField>& extra, std::string_view state) {
  w.clear();
  w.begin_object();
  if (!state.empty()) {
    w.key("state");
    w.value(state);
  }
  w.key("frames");
  w.value(frames);
  w.key("seconds");
  w.value(seconds);
  w.key("fps");
  w.value(seconds > 0 ? static_cast<double>(frames) / seconds : 0.0);
  for (const StatsExtraField& f : extra) {
    w.key(f.name);
    w.value(f.value);
  }
  w.key("stages");
  w.begin_object();
  for (std::size_t i = 0; i < stats.num_stages(); ++i) {
    const StageSummary s = stats.summary(static_cast<int>(i));
    w.key(stats.stage_name(static_cast<int>(i)));
    w.begin_object();
    w.key("median_ms");
    w.value(s.median_ms);
    w.key("p95_ms");
    w.value(s.p95_ms);
    w.key("mean_ms");
    w.value(s.mean_ms);
    w.key("max_ms");
    w.value(s.max_ms);
    w.key("count");
    w.value(s.count);
    w.end_object();
  }
  w.end_object();
  w.key("counters");
  w.begin_object();
  for (std::size_t i = 0; i < stats.num_counters(); ++i) {
    w.key(stats.counter_name(static_cast<int>(i)));
    w.value(stats.counter(static_cast<int>(i)));
  }
  w.end_object();
  w.end_object();
  w.raw("\n");
}

std::string stats_to_json(const StageStats& stats, uint64_t frames, double seconds,
                          const std::vector<StatsExtraField>& extra, std::string_view state) {
  JsonWriter w;
  write_stats_object(w, stats, frames, seconds, extra, state);
  return w.str();
}

Status write_stats_json(const std::string& path, const StageStats& stats, uint64_t frames, double seconds,
                        const std::vector<StatsExtraField>& extra, std::string_view state) {
  const std::string text = stats_to_json(stats, frames, seconds, extra, state);
  return write_file_whole(path, {{text.data(), text.size()}});  // whole or not at all
}

}  // namespace ef
