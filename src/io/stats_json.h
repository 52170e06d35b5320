// stats.json: the run's summary, rewritten during the run and at its end.
//   {"state":"...","frames":N,"seconds":s,"fps":f,<extra numeric fields>,
//    "stages":{"<name>":{"median_ms":..,"p95_ms":..,"mean_ms":..,"max_ms":..,"count":..},...},
//    "counters":{"<name>":n,...}}
// fps = frames / seconds (end to end; 0 when seconds <= 0). Stages and counters appear in
// registration order. Non-finite numbers are written as null. "state" (when given): "running",
// "finished", "stopped", "camera lost" or "failed: <reason>" (pipeline/run_pipeline.h).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "core/result.h"
#include "core/stage_stats.h"

namespace ef {

// A minimal streaming JSON writer into a string: commas and key escaping handled, no pretty printing.
class JsonWriter {
 public:
  void begin_object();
  void end_object();
  void key(std::string_view k);  // inside an object, before a value
  void value(double v);          // shortest form that reads back exactly; null when not finite
  void value(int64_t v);
  void value(uint64_t v);
  void value(int v) { value(static_cast<int64_t>(v)); }
  void value(std::string_view s);
  void value_null();
  void value_bool(bool b);
  void raw(std::string_view text) { out_ += text; }  // appended as it is (no comma, no quoting)
  const std::string& str() const { return out_; }
  // Empties the text, keeping its capacity: with reserve() big enough, writing allocates nothing.
  void clear();
  void reserve(std::size_t bytes, std::size_t depth = 8);

  // Appends s as a JSON string literal (quotes, \" \\ \n \r \t \b \f, other control bytes as \u00XX;
  // bytes >= 0x80 pass through unchanged, so UTF-8 stays UTF-8).
  static void append_escaped(std::string& out, std::string_view s);

 private:
  void before_value();
  std::string out_;
  std::vector<bool> first_;  // per open container: no element written yet
  bool after_key_ = false;
};

struct StatsExtraField {
  std::string name;
  double value = 0;  // integral values print without a decimal point (e.g. peak_rss_bytes)
};

// The JSON text of stats.json (ends with a newline) into `w` (cleared first). Allocates nothing when
// w's capacity holds the text (JsonWriter::reserve) and every name fits it.
void write_stats_object(JsonWriter& w, const StageStats& stats, uint64_t frames, double seconds,
                        const std::vector<StatsExtraField>& extra = {}, std::string_view state = {});
std::string stats_to_json(const StageStats& stats, uint64_t frames, double seconds,
                          const std::vector<StatsExtraField>& extra = {}, std::string_view state = {});

// Writes stats_to_json(...) to `path`, whole or not at all (io/durable_file.h).
Status write_stats_json(const std::string& path, const StageStats& stats, uint64_t frames, double seconds,
                        const std::vector<StatsExtraField>& extra = {}, std::string_view state = {});

}  // namespace ef
