#include "pipeline/run_config.h"

#include <sstream>

#include "pipeline/run_folder.h"
#include "platform/cpu/thread_affinity.h"

namespace ef::pipeline {

// ---- The pipeline's own tables ----

const opt::Table<RunOptions>& RunOptions::table() {
  static const opt::Table<RunOptions> t = {
      {"source", "", "--source", &RunOptions::source, "a source URI", opt::any(),
       "frame source URI (edgefusion run --help lists them)"},
      {"resolution", "", "--resolution", &RunOptions::resolution, "pixels", opt::between(32, 8192),
       "working resolution of tracking and label fusion, WIDTHxHEIGHT (at least 32x32: the tracker's coarsest "
       "level, a quarter of it, must be 8x8; 160x120 for the smallest boards)"},
      {"frames", "", "--frames", &RunOptions::frames, "frames", opt::at_least(1).or_value(-1, "all the source has"),
       "how many to process, from the first"},
      {"out", "", "--out", &RunOptions::out, "a folder", opt::any(),
       "output folder, created if missing; run needs it here or as --out. A folder that holds an earlier run is "
       "refused (output.overwrite); {time} in it gives each run its own folder, named by its start time, with a "
       "link `latest` beside it to the newest"},
      {"progress", "", "--quiet", &RunOptions::progress, "", opt::any(), "progress line on stderr"},
      {"map", "", "", &RunOptions::map, "", opt::any(), "write map.ply at the end of the run"},
      {"preview", "", "--no-preview", &RunOptions::preview, "", opt::any(),
       "write preview.png with each checkpoint and at the end of the run: the map in colour and in its "
       "classes, the camera's path, a legend (edgefusion view draws any map the same way)"},
      {"report", "", "--no-report", &RunOptions::report, "", opt::any(),
       "write report.html at the end of the run: one self-contained page with the map's picture, the path from "
       "above, the stages' times, the rate over the run, the counters, the map's classes and the configuration"},
      {"realtime", "", "--realtime", &RunOptions::realtime, "", opt::any(),
       "replay a recording at its recorded speed instead of as fast as possible"},
  };
  return t;
}

Status RunOptions::validate() const { return opt::check_table(*this, table(), "run"); }

const opt::Table<LabelOptions>& LabelOptions::table() {
  static const opt::Table<LabelOptions> t = {
      {"enabled", "labels", "--no-labels", &LabelOptions::enabled, "", opt::any(),
       "CNN segmentation and Bayesian label fusion; false = geometry only"},
      {"model", "model", "--model", &LabelOptions::model, "a .efm file", opt::any(),
       "segmentation model; none = the shipped one for the source: models/deeplabv3-mnv2-nyu13.efm (real "
       "photographs) for recordings and cameras, models/edgefusion-seg.efm for the synthetic rooms "
       "($EDGEFUSION_MODEL overrides both)"},
      {"out", "labels_out", "--labels-out", &LabelOptions::out, "a folder", opt::any(),
       "folder for the map's labels rendered into every out_every-th frame as it arrives (class-id PNGs; the same "
       "in the paper's palette into the folder beside it, named like it with _color)"},
      {"out_every", "labels_out_every", "--labels-out-every", &LabelOptions::out_every, "frames",
       opt::between(1, 1'000'000), "write every K-th frame's rendering, counted from the first"},
      {"final_out", "labels_final_out", "--labels-final-out", &LabelOptions::final_out, "a folder", opt::any(),
       "recordings only: after the run, read the recording again and write the finished map's labels in every "
       "out_every-th frame, at the estimated poses, into this folder"},
  };
  return t;
}

Status LabelOptions::validate() const { return opt::check_table(*this, table(), "labels"); }

const opt::Table<CrfOptions>& CrfOptions::table() {
  static const opt::Table<CrfOptions> t = {
      {"every", "crf_every", "--crf-every", &CrfOptions::every, "frames", opt::between(1, 1'000'000).or_value(0, "off"),
       "how often the dense CRF runs over the whole map (the paper: every 500)"},
      {"final", "crf_final", "--crf-final", &CrfOptions::final, "", opt::any(),
       "one dense CRF over the whole map at the end of the run, before map.ply is written"},
      {"capacity", "crf_capacity", "", &CrfOptions::capacity, "surfels",
       opt::between(1, 100'000'000 / 7).or_value(0, "derived"),
       "most surfels the CRF takes (the confident ones seen most recently); 0 = the pool's capacity, or fewer if the "
       "memory budget leaves less (edgefusion plan shows it)"},
  };
  return t;
}

Status CrfOptions::validate() const { return opt::check_table(*this, table(), "crf"); }

const opt::Table<PipelineOptions>& PipelineOptions::table() {
  constexpr opt::Range kCore = opt::between(0, 1023).or_value(-1, "not pinned");
  static const opt::Table<PipelineOptions> t = {
      {"threads", "threads", "--threads", &PipelineOptions::threads, "", opt::between(1, 3),
       "1 = front (read, resample, preprocess), CNN and mapping take turns on one thread; 2 = front and the CNN "
       "on one core beside mapping; 3 = each on its own; the geometry is the same in every mode"},
      {"deterministic", "deterministic", "--deterministic", &PipelineOptions::deterministic, "", opt::any(),
       "the CNN takes exactly every label_every-th frame and mapping waits for its result: outputs that do not "
       "depend on timing (those of threads 1); false = the CNN never holds the mapper back"},
      {"prepared_slots", "", "", &PipelineOptions::prepared_slots, "frames", opt::between(2, 16),
       "how many frames are in flight between front and mapping"},
      {"capture_slots", "", "", &PipelineOptions::capture_slots, "frames", opt::between(2, 64),
       "live cameras: how many frames wait between capture and the front step (full: the oldest is dropped, "
       "counted)"},
      {"front_cpu", "", "", &PipelineOptions::front_cpu, "", kCore, "CPU core the front step's thread is pinned to"},
      {"cnn_cpu", "", "", &PipelineOptions::cnn_cpu, "", kCore, "CPU core the CNN's thread is pinned to with threads 3 (with 2 it shares front_cpu)"},
      {"mapping_cpu", "", "", &PipelineOptions::mapping_cpu, "", kCore, "CPU core the mapping thread is pinned to"},
      {"capture_cpu", "", "", &PipelineOptions::capture_cpu, "", kCore,
       "CPU core a live camera's capture thread is pinned to"},
      {"pinning", "", "", &PipelineOptions::pinning, "", opt::any(),
       "keys = the *_cpu keys pin the threads; auto = chosen at start-up from the cores present (mapping on the "
       "last, the CNN on the one before, the front step before that, capture on the first; fewer cores share; "
       "one core pins nothing), so one configuration fits any board"},
  };
  return t;
}

Status PipelineOptions::validate() const {
  EF_RETURN_IF_ERROR(opt::check_table(*this, table(), "pipeline"));
  if (pinning != "keys" && pinning != "auto")
    return error(ErrorCode::kInvalidArgument, "pipeline: pinning '" + pinning + "' is not keys or auto");
  if (pinning == "auto") {
    std::string set;
    for (const auto& [key, cpu] : {std::pair<const char*, int>{"capture_cpu", capture_cpu}, {"front_cpu", front_cpu},
                                   {"cnn_cpu", cnn_cpu}, {"mapping_cpu", mapping_cpu}})
      if (cpu >= 0) set += (set.empty() ? "" : ", ") + std::string(key) + " " + std::to_string(cpu);
    if (!set.empty())
      return error(ErrorCode::kInvalidArgument, "pipeline: pinning auto chooses the cores itself, but " + set +
                                                    " also pin; leave them at -1 or set pinning: keys");
  }
  return Status::success();
}

PipelineOptions PipelineOptions::pinned_for(const std::vector<int>& cores) const {
  PipelineOptions p = *this;
  if (pinning != "auto" || cores.size() < 2) return p;
  const std::size_t n = cores.size();
  p.mapping_cpu = cores[n - 1];
  p.cnn_cpu = cores[n - 2];
  p.front_cpu = n >= 4 ? cores[n - 3] : cores[0];
  p.capture_cpu = cores[0];
  return p;
}

std::string PipelineOptions::pinning_text() const {
  std::string s;
  for (const auto& [name, cpu] : {std::pair<const char*, int>{"capture", capture_cpu}, {"front", front_cpu},
                                  {"CNN", cnn_cpu}, {"mapping", mapping_cpu}})
    if (cpu >= 0) s += (s.empty() ? "" : ", ") + std::string(name) + " " + std::to_string(cpu);
  return s.empty() ? "none" : s;
}

const opt::Table<MemoryOptions>& MemoryOptions::table() {
  static const opt::Table<MemoryOptions> t = {
      {"budget_mb", "memory_budget_mb", "--memory-budget-mb", &MemoryOptions::budget_mb, "MB (10^6 bytes)",
       opt::between(1, 1'000'000), "a run refuses to start when its memory plan is larger"},
  };
  return t;
}

Status MemoryOptions::validate() const { return opt::check_table(*this, table(), "memory"); }

const opt::Table<OutputOptions>& OutputOptions::table() {
  static const opt::Table<OutputOptions> t = {
      {"sync_seconds", "", "--sync-seconds", &OutputOptions::sync_seconds, "s", opt::between(0, 3600),
       "trajectory.txt is synced to the disk at most this long after a line (a power cut loses no more); 0 = "
       "after every line"},
      {"stats_seconds", "", "--stats-seconds", &OutputOptions::stats_seconds, "s",
       opt::between(0.1, 86400).or_value(0, "at the start and the end only"),
       "stats.json is rewritten whole (state \"running\") this often during the run"},
      {"overwrite", "", "--overwrite", &OutputOptions::overwrite, "", opt::any(),
       "replace the outputs of an earlier run in `out`; otherwise a folder that holds one is refused"},
      {"checkpoint_seconds", "", "--checkpoint-seconds", &OutputOptions::checkpoint_seconds, "s",
       opt::between(0.1, 86400).or_value(0, "none"),
       "the whole map state is written to checkpoint.efs this often and at the end (run --resume DIR continues "
       "from it; edgefusion export DIR writes its map.ply)"},
      {"resume_interrupted", "", "--resume-interrupted", &OutputOptions::resume_interrupted, "", opt::any(),
       "with \"{time}\" in `out`: when the newest run there (its `latest` link) did not end (a power cut, a kill: "
       "stats.json says \"running\") or lost its camera, and has a checkpoint, continue it in its folder with its "
       "configuration instead of starting a new one (the service's restart after a power cut)"},
  };
  return t;
}

Status OutputOptions::validate() const { return opt::check_table(*this, table(), "output"); }

// ---- The keys, bound into RunConfig ----

namespace {

// Adds the rows of `table` as keys of `section`, each name prefixed by `prefix` and its help by
// `help_prefix`. `part` picks the struct out of a RunConfig (const or not).
template <class S, class Part>
void bind_table(std::vector<ConfigKey>& keys, const std::string& section, const std::string& prefix,
                const std::string& help_prefix, const opt::Table<S>& table, Part part) {
  const RunConfig defaults;
  for (const opt::Option<S>& o : table) {
    ConfigKey k;
    k.path = (section.empty() ? "" : section + ".") + prefix + o.name;
    k.flat = o.flat;
    k.flag = o.flag;
    k.unit = o.unit;
    k.help = help_prefix + o.help;
    k.range = o.range;
    k.kind = opt::get(part(defaults), o).kind;
    k.get = [o, part](const RunConfig& c) { return opt::get(part(c), o); };
    k.parse = [o, part](RunConfig& c, const std::string& text) { return opt::parse_into(part(c), o, text); };
    if (k.kind == opt::Value::kBool) {
      const bool flag_value = !opt::get(part(defaults), o).b;
      k.set_flag = [o, part, flag_value](RunConfig& c) {
        opt::Value v;
        v.kind = opt::Value::kBool;
        v.b = flag_value;
        opt::set(part(c), o, v);
      };
    }
    keys.push_back(std::move(k));
  }
}

std::vector<ConfigKey> make_keys() {
  std::vector<ConfigKey> k;
  bind_table(k, "", "", "", RunOptions::table(), [](auto& c) -> auto& { return c.run; });
  bind_table(k, "mapping", "", "", slam::SurfelPoolOptions::table(), [](auto& c) -> auto& { return c.mapping.pool; });
  bind_table(k, "mapping", "", "", slam::TrackerOptions::table(), [](auto& c) -> auto& { return c.mapping.tracker; });
  bind_table(k, "mapping", "", "", slam::SurfelSlamOptions::table(), [](auto& c) -> auto& { return c.mapping; });
  bind_table(k, "mapping", "", "", slam::PreprocessOptions::table(), [](auto& c) -> auto& { return c.mapping.preprocess; });
  bind_table(k, "mapping", "", "", slam::PredictionOptions::table(), [](auto& c) -> auto& { return c.mapping.prediction; });
  bind_table(k, "mapping", "", "", slam::FusionOptions::table(), [](auto& c) -> auto& { return c.mapping.fusion; });
  bind_table(k, "mapping", "", "", slam::KeyframeFernOptions::table(), [](auto& c) -> auto& { return c.mapping.ferns; });
  bind_table(k, "mapping", "", "", slam::DeformationGraphOptions::table(), [](auto& c) -> auto& { return c.mapping.graph; });
  bind_table(k, "labels", "", "", LabelOptions::table(), [](auto& c) -> auto& { return c.labels; });
  bind_table(k, "labels", "", "", semantic::LabelFusionOptions::table(), [](auto& c) -> auto& { return c.label_fusion; });
  bind_table(k, "crf", "", "", CrfOptions::table(), [](auto& c) -> auto& { return c.crf; });
  bind_table(k, "crf", "", "", semantic::DenseCrfOptions::table(), [](auto& c) -> auto& { return c.dense_crf; });
  bind_table(k, "pipeline", "", "", PipelineOptions::table(), [](auto& c) -> auto& { return c.pipeline; });
  bind_table(k, "memory", "", "", MemoryOptions::table(), [](auto& c) -> auto& { return c.memory; });
  bind_table(k, "output", "", "", OutputOptions::table(), [](auto& c) -> auto& { return c.output; });
  bind_table(k, "log", "", "", McapLogOptions::table(), [](auto& c) -> auto& { return c.log; });
  bind_table(k, "gpio", "led_", "status LED: ", GpioLineConfig::table(), [](auto& c) -> auto& { return c.gpio.led; });
  bind_table(k, "gpio", "button_", "start/stop button: ", GpioLineConfig::table(),
       [](auto& c) -> auto& { return c.gpio.button; });
  bind_table(k, "gpio", "", "", GpioOptions::table(), [](auto& c) -> auto& { return c.gpio; });
  return k;
}

}  // namespace

std::string ConfigKey::section() const {
  const auto dot = path.find('.');
  return dot == std::string::npos ? std::string() : path.substr(0, dot);
}

std::string ConfigKey::name() const {
  const auto dot = path.find('.');
  return dot == std::string::npos ? path : path.substr(dot + 1);
}

std::string ConfigKey::doc() const { return opt::describe_row(help.c_str(), unit.c_str(), range, get(RunConfig())); }

const std::vector<ConfigKey>& config_keys() {
  static const std::vector<ConfigKey> keys = make_keys();
  return keys;
}

const ConfigKey* find_config_key(const std::string& key) {
  for (const ConfigKey& k : config_keys())
    if (key == k.path || (!k.flat.empty() && key == k.flat)) return &k;
  return nullptr;
}

const std::vector<std::string>& config_sections() {
  static const std::vector<std::string> sections = [] {
    std::vector<std::string> s;
    for (const ConfigKey& k : config_keys()) {
      const std::string sec = k.section();
      if (!sec.empty() && (s.empty() || s.back() != sec)) s.push_back(sec);
    }
    return s;
  }();
  return sections;
}

std::string RunConfig::describe() const {
  std::ostringstream o;
  o << "# edgefusion configuration (YAML): every option with its unit, range and default.\n"
       "# Flat names (surfel_capacity, label_every, crf_iterations, ...) also work at the top level.\n";
  std::string section;
  for (const ConfigKey& k : config_keys()) {
    const std::string sec = k.section();
    if (sec != section) {
      o << sec << ":\n";
      section = sec;
    }
    const std::string value = opt::yaml_text(k.get(*this));
    std::string line = (sec.empty() ? "" : "  ") + std::string(value.empty() ? "# " : "") + k.name() + ":" +
                       (value.empty() ? "" : " " + value);
    if (line.size() < 34) line.resize(34, ' ');
    o << line << " # " << k.doc() << "\n";
  }
  return o.str();
}

std::string config_keys_markdown() {
  std::string s =
      "| key | flat name | flag | default | unit, range | what it does |\n"
      "|---|---|---|---|---|---|\n";
  const RunConfig defaults;
  for (const ConfigKey& k : config_keys()) {
    const opt::Value d = k.get(defaults);
    std::string def = opt::yaml_text(d);
    if (def.empty()) def = "none";
    std::string unit_range = k.kind == opt::Value::kText ? std::string() : k.unit;
    const std::string r = k.kind == opt::Value::kText || k.kind == opt::Value::kBool ? "" : k.range.text();
    if (!r.empty()) unit_range += (unit_range.empty() ? "" : ", ") + r;
    const auto code = [](const std::string& t) { return t.empty() ? std::string() : "`" + t + "`"; };
    std::string help = k.help;
    for (std::size_t at = help.find('|'); at != std::string::npos; at = help.find('|', at + 2)) help.replace(at, 1, "\\|");
    s += "| " + code(k.path) + " | " + code(k.flat) + " | " + code(k.flag) + " | " + code(def) + " | " + unit_range +
         " | " + help + " |\n";
  }
  return s;
}

// ---- Checks ----

Status RunConfig::validate() const { return validate(usable_cpu_cores()); }

Status RunConfig::validate(const std::vector<int>& cores) const {
  // Each part on its own (ranges from its table, its rules between fields).
  EF_RETURN_IF_ERROR(run.validate());
  EF_RETURN_IF_ERROR(mapping.validate());
  EF_RETURN_IF_ERROR(labels.validate());
  EF_RETURN_IF_ERROR(label_fusion.validate());
  EF_RETURN_IF_ERROR(crf.validate());
  if (labels.enabled && crf.on()) EF_RETURN_IF_ERROR(crf_options_for_run(*this).validate());
  EF_RETURN_IF_ERROR(pipeline.validate());
  EF_RETURN_IF_ERROR(memory.validate());
  EF_RETURN_IF_ERROR(output.validate());
  EF_RETURN_IF_ERROR(log.validate());
  EF_RETURN_IF_ERROR(gpio.validate());

  // Between the parts.
  if (run.out.empty())
    return error(ErrorCode::kInvalidArgument, "missing --out DIR (or 'out:' in --config): where the run writes");
  if (!labels.enabled && (!labels.out.empty() || !labels.final_out.empty() || crf.on()))
    return error(ErrorCode::kInvalidArgument,
                 "--labels-out, --labels-final-out and the CRF need labels: drop --no-labels (or 'labels: false')");
  // A spacing for images no one asked for would be ignored without a word.
  if (labels.out.empty() && labels.final_out.empty() && labels.out_every != LabelOptions{}.out_every)
    return error(ErrorCode::kInvalidArgument, "--labels-out-every " + std::to_string(labels.out_every) +
                                                  " (labels.out_every) spaces the label images of --labels-out DIR "
                                                  "or --labels-final-out DIR: give one of them");

  // The machine: every pinned core must exist; all the keys that name a missing one, at once.
  std::string missing;
  for (const auto& [key, cpu] : {std::pair<const char*, int>{"pipeline.capture_cpu", pipeline.capture_cpu},
                                 {"pipeline.front_cpu", pipeline.front_cpu},
                                 {"pipeline.cnn_cpu", pipeline.cnn_cpu},
                                 {"pipeline.mapping_cpu", pipeline.mapping_cpu}}) {
    if (cpu < 0) continue;  // not pinned
    bool found = false;
    for (int c : cores) found = found || c == cpu;
    if (!found) missing += (missing.empty() ? "" : ", ") + std::string(key) + " " + std::to_string(cpu);
  }
  if (!missing.empty())
    return error(ErrorCode::kInvalidArgument,
                 missing + ": no such core on this machine, which lets this process use " + cores_text(cores) +
                     ". Set these keys to -1 (not pinned) or to cores it has");
  return Status::success();
}

Status check_run(const RunConfig& config, const SourceProbe& source) {
  EF_RETURN_IF_ERROR(check_out_folder(config.run, config.output));
  if (!config.labels.final_out.empty() && source.live)
    return error(ErrorCode::kInvalidArgument, "--labels-final-out reads the source a second time after the run; " +
                                                  config.run.source +
                                                  " is a live camera (record it first, e.g. to .klg)");
  return Status::success();
}

semantic::DenseCrfOptions crf_options_for_run(const RunConfig& config, int64_t nodes) {
  semantic::DenseCrfOptions co = config.dense_crf;
  co.capacity = nodes > 0 ? nodes : config.crf.capacity > 0 ? config.crf.capacity : config.mapping.pool.capacity;
  // Lattice vertices per surfel of capacity. A SurfelSlam map needs more than the CRF's default
  // (0.3, measured on noise-free sampled surfaces): on the synthetic seed-5001 loop (370k surfels
  // after 300 frames) the spatial kernel's lattice had 1.13 vertices per surfel (noisy normals
  // spread it) and the bilateral one 0.80. 1.25 leaves none out there; the cost is
  // DenseCrf::kBytesPerVertex per vertex (docs/architecture.md, memory budget).
  co.max_lattice_vertices = co.capacity * 5 / 4;
  return co;
}

}  // namespace ef::pipeline
