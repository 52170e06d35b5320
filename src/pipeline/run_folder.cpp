#include "pipeline/run_folder.h"

#include <cstdio>
#include <filesystem>

#include "io/durable_file.h"
#include "pipeline/checkpoint.h"

namespace ef::pipeline {

namespace fs = std::filesystem;

namespace {

// The run's outputs present in `folder`, comma-separated ("" when none).
std::string run_files_in(const fs::path& folder) {
  std::string found;
  std::error_code ec;
  for (const char* name : kRunFiles)
    if (fs::exists(folder / name, ec)) found += (found.empty() ? "" : ", ") + std::string(name);
  return found;
}

bool has_time_placeholder(const std::string& out) { return out.find(kTimePlaceholder) != std::string::npos; }

// Points `<parent>/latest` at `name` (relative), replacing an earlier link in one rename.
Status update_latest_link(const fs::path& parent, const std::string& name) {
  const fs::path link = parent / "latest";
  const fs::path temp = parent / ".latest.partial";
  std::error_code ec;
  fs::remove(temp, ec);
  fs::create_directory_symlink(name, temp, ec);
  if (!ec) fs::rename(temp, link, ec);  // rename(2) replaces a link, never a real folder of that name
  if (ec) {
    fs::remove(temp, ec);
    return error(ErrorCode::kIoError, link.string() + ": cannot point it at " + name + ": " + ec.message());
  }
  return sync_folder(parent.string());
}

}  // namespace

Status check_out_folder(const RunOptions& run, const OutputOptions& output) {
  if (output.resume) {
    if (!fs::is_directory(run.out))
      return error(ErrorCode::kNotFound, "--resume: '" + run.out + "' is not a run folder");
    return Status::success();
  }
  if (output.overwrite || has_time_placeholder(run.out)) return Status::success();
  const std::string found = run_files_in(run.out);
  if (found.empty()) return Status::success();
  return error(ErrorCode::kInvalidArgument,
               "output folder '" + run.out + "' holds an earlier run (" + found +
                   "): a run never overwrites another. Choose another --out, put {time} in it for a folder per "
                   "run, or give --overwrite (output.overwrite: true) to replace that run's outputs");
}

std::string run_state(const std::string& folder) {
  // stats.json starts {"state":"<text>", (io/stats_json.h); the text is JSON-escaped.
  std::FILE* f = std::fopen((fs::path(folder) / "stats.json").c_str(), "rb");
  if (f == nullptr) return {};
  char head[512];
  const std::size_t n = std::fread(head, 1, sizeof head, f);
  std::fclose(f);
  const std::string text(head, n);
  constexpr const char* kKey = "{\"state\":\"";
  if (text.rfind(kKey, 0) != 0) return {};
  std::string state;
  for (std::size_t i = std::char_traits<char>::length(kKey); i < text.size(); ++i) {
    if (text[i] == '"') return state;
    if (text[i] == '\\' && i + 1 < text.size()) ++i;  // an escaped character: keep it as is
    state += text[i];
  }
  return {};  // cut off before its closing quote
}

InterruptedRun find_interrupted_run(const RunOptions& run) {
  InterruptedRun r;
  const fs::path out(run.out);
  if (out.filename().string().find(kTimePlaceholder) == std::string::npos) {
    r.why = "output.resume_interrupted needs \"{time}\" in the last part of out ('" + run.out + "')";
    return r;
  }
  const fs::path parent = out.parent_path().empty() ? fs::path(".") : out.parent_path();
  const fs::path link = parent / "latest";
  std::error_code ec;
  const fs::path target = fs::read_symlink(link, ec);
  if (ec || !fs::is_directory(link, ec)) {
    r.why = "no earlier run (" + link.string() + " does not point to a run folder)";
    return r;
  }
  const std::string folder = (target.is_absolute() ? target : parent / target).lexically_normal().string();
  r.state = run_state(folder);
  if (r.state != "running" && r.state != "camera lost") {
    r.why = "the newest run " + folder + " ended (" + (r.state.empty() ? "no stats.json" : r.state) + ")";
    return r;
  }
  auto found = find_checkpoint(folder);
  if (!found.ok()) {
    r.why = "the newest run " + folder + " (" + r.state + ") has no usable checkpoint: " + found.error().message;
    return r;
  }
  r.frames = found->meta.frames;
  r.folder = folder;
  return r;
}

Result<std::string> prepare_out_folder(const RunOptions& run, const OutputOptions& output, std::time_t now) {
  std::string out = run.out;
  while (out.size() > 1 && out.back() == '/') out.pop_back();
  std::string run_name;  // the folder's own name, when {time} made it
  std::error_code ec;
  if (output.resume) {
    EF_RETURN_IF_ERROR(check_out_folder(run, output));
  } else if (has_time_placeholder(out)) {
    std::tm local{};
    localtime_r(&now, &local);
    char stamp[32];
    std::strftime(stamp, sizeof stamp, "%Y%m%d-%H%M%S", &local);
    const std::size_t at = out.find(kTimePlaceholder);
    const std::string base = out.substr(0, at) + stamp, tail = out.substr(at + std::char_traits<char>::length(kTimePlaceholder));
    out = base + tail;
    // Two runs within one second (a fast restart): the second gets "-2", and so on.
    for (int n = 2; fs::exists(out, ec) && n < 1000; ++n) out = base + "-" + std::to_string(n) + tail;
    run_name = fs::path(out).filename().string();
  } else if (!output.overwrite) {
    EF_RETURN_IF_ERROR(check_out_folder(run, output));
  }
  fs::create_directories(out, ec);
  if (ec) return error(ErrorCode::kIoError, "cannot create output folder '" + out + "': " + ec.message());

  // An earlier run's outputs (overwrite) and a killed run's leftovers.
  for (const char* name : kRunFiles) {
    if (output.overwrite && !output.resume) fs::remove(fs::path(out) / name, ec);
    fs::remove(fs::path(out) / (std::string(name) + ".partial"), ec);
    fs::remove(fs::path(out) / ("." + std::string(name) + ".next"), ec);
  }
  if (!run_name.empty()) {
    const fs::path parent = fs::path(out).parent_path();
    EF_RETURN_IF_ERROR(update_latest_link(parent.empty() ? fs::path(".") : parent, run_name));
  }
  return out;
}

}  // namespace ef::pipeline
