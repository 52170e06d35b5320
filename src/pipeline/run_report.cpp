#include "pipeline/run_report.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "core/classes.h"
#include "io/durable_file.h"
#include "pipeline/map_preview.h"

namespace ef::pipeline {

namespace {

// HTML text: the five characters that mean something there, escaped.
std::string esc(const std::string& s) {
  std::string o;
  o.reserve(s.size());
  for (char c : s) {
    switch (c) {
      case '&': o += "&amp;"; break;
      case '<': o += "&lt;"; break;
      case '>': o += "&gt;"; break;
      case '"': o += "&quot;"; break;
      case '\'': o += "&#39;"; break;
      default: o += c;
    }
  }
  return o;
}

// Appends `file` base64-encoded (RFC 4648) to `out`, 48 kB at a time. False when it cannot be read.
bool base64_file(std::FILE* out, const std::string& file) {
  static const char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::FILE* in = std::fopen(file.c_str(), "rb");
  if (in == nullptr) return false;
  unsigned char buf[48 * 1024];  // a multiple of 3: only the last piece is padded
  char enc[64 * 1024 + 4];
  std::size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, in)) > 0) {
    std::size_t o = 0;
    for (std::size_t i = 0; i < n; i += 3) {
      const unsigned v = (unsigned(buf[i]) << 16) | (i + 1 < n ? unsigned(buf[i + 1]) << 8 : 0u) |
                         (i + 2 < n ? unsigned(buf[i + 2]) : 0u);
      enc[o++] = kAlphabet[(v >> 18) & 63];
      enc[o++] = kAlphabet[(v >> 12) & 63];
      enc[o++] = i + 1 < n ? kAlphabet[(v >> 6) & 63] : '=';
      enc[o++] = i + 2 < n ? kAlphabet[v & 63] : '=';
    }
    std::fwrite(enc, 1, o, out);
  }
  const bool ok = std::ferror(in) == 0;
  std::fclose(in);
  return ok;
}

const char* kStyle =
    "body{font:14px/1.45 system-ui,-apple-system,'Segoe UI',sans-serif;margin:24px auto;max-width:1320px;"
    "color:#222;background:#fff;padding:0 16px}h1{font-size:22px;margin:0 0 4px}h2{font-size:17px;"
    "margin:28px 0 8px;border-bottom:1px solid #ddd;padding-bottom:4px}table{border-collapse:collapse}"
    "td,th{padding:3px 10px;border-bottom:1px solid #eee;text-align:left}td.n,th.n{text-align:right;"
    "font-variant-numeric:tabular-nums}img{max-width:100%;border:1px solid #ddd}pre{background:#f6f6f6;"
    "padding:10px;overflow:auto;font-size:12px}.facts td:first-child{color:#666}.sw{display:inline-block;"
    "width:12px;height:12px;vertical-align:middle;margin-right:6px;border:1px solid #999}"
    ".cols{display:flex;gap:32px;flex-wrap:wrap}svg text{font:12px system-ui,sans-serif;fill:#444}";

}  // namespace

TopView top_view(const SurfelCloudView& cloud, const std::vector<SE3>& path,
                 const std::vector<Eigen::Vector3d>& reference, int max_points) {
  TopView v;
  if (cloud.count == 0) return v;
  PreviewOptions o;
  o.top = true;
  o.width = 1000;
  o.height = 750;
  const PreviewCamera cam = frame_map(cloud, path, o);
  const SE3 T_cw = cam.T_world_cam.inverse();
  const auto project = [&](const Eigen::Vector3d& p_world, std::vector<std::pair<float, float>>& out) {
    const Eigen::Vector3d p = T_cw * p_world;
    if (p.z() <= 1e-3) return;
    out.emplace_back(static_cast<float>(cam.intrinsics.fx * p.x() / p.z() + cam.intrinsics.cx),
                     static_cast<float>(cam.intrinsics.fy * p.y() / p.z() + cam.intrinsics.cy));
  };
  const std::size_t step = std::max<std::size_t>(1, (cloud.count + max_points - 1) / static_cast<std::size_t>(max_points));
  for (std::size_t i = 0; i < cloud.count; i += step) project(Eigen::Vector3d(cloud.x[i], cloud.y[i], cloud.z[i]), v.outline);
  for (const SE3& T : path) project(T.translation(), v.path);
  for (const Eigen::Vector3d& c : reference) project(c, v.reference);
  v.height = static_cast<float>(o.height);
  return v;
}

Status write_run_report(const std::string& path, const ReportInputs& in, const TopView& top) {
  FileReplacement file(path);
  std::FILE* f = std::fopen(file.temp_path().c_str(), "wb");
  if (f == nullptr) return error(ErrorCode::kIoError, path + ": cannot create: " + std::strerror(errno));
  const double fps = in.seconds > 0 ? static_cast<double>(in.frames) / in.seconds : 0.0;
  std::fprintf(f,
               "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>EdgeFusion run: %s</title>"
               "<style>%s</style></head><body>\n",
               esc(in.title).c_str(), kStyle);
  std::fprintf(f, "<h1>EdgeFusion run</h1><div>%s</div>\n<h2>Summary</h2><table class=\"facts\">\n",
               esc(in.title).c_str());
  std::fprintf(f, "<tr><td>state</td><td>%s</td></tr>\n<tr><td>frames</td><td>%lld in %.2f s (%.1f fps)</td></tr>\n",
               esc(in.state).c_str(), static_cast<long long>(in.frames), in.seconds, fps);
  for (const auto& [k, v] : in.facts)
    std::fprintf(f, "<tr><td>%s</td><td>%s</td></tr>\n", esc(k).c_str(), esc(v).c_str());
  std::fprintf(f, "</table>\n");

  // The map.
  std::fprintf(f, "<h2>The map</h2>\n");
  bool embedded = false;
  if (!in.preview_png.empty()) {
    std::fprintf(f, "<img alt=\"the map in colour and in its classes\" src=\"data:image/png;base64,");
    embedded = base64_file(f, in.preview_png);
    std::fprintf(f, "\">\n");
  }
  if (!embedded) std::fprintf(f, "<p>(no preview.png: the run wrote none)</p>\n");

  // The path from above, over the map's outline.
  std::fprintf(f, "<h2>The camera's path from above</h2>\n");
  if (top.outline.empty()) {
    std::fprintf(f, "<p>(no map)</p>\n");
  } else {
    std::fprintf(f, "<svg viewBox=\"0 0 1000 %.0f\" width=\"720\" role=\"img\" aria-label=\"path from above\">"
                    "<rect width=\"1000\" height=\"%.0f\" fill=\"#fafafa\"/>\n",
                 top.height, top.height);
    for (const auto& [x, y] : top.outline) std::fprintf(f, "<circle cx=\"%.0f\" cy=\"%.0f\" r=\"2\" fill=\"#bbb\"/>", x, y);
    if (top.reference.size() >= 2) {
      std::fprintf(f, "\n<polyline fill=\"none\" stroke=\"#3a6fb0\" stroke-width=\"2\" stroke-dasharray=\"8 5\" points=\"");
      for (const auto& [x, y] : top.reference) std::fprintf(f, "%.1f,%.1f ", x, y);
      std::fprintf(f, "\"/>\n");
    }
    if (top.path.size() >= 2) {
      std::fprintf(f, "\n<polyline fill=\"none\" stroke=\"#c81ea0\" stroke-width=\"3\" points=\"");
      for (const auto& [x, y] : top.path) std::fprintf(f, "%.1f,%.1f ", x, y);
      std::fprintf(f, "\"/>\n");
    }
    if (!top.path.empty()) {
      std::fprintf(f, "<circle cx=\"%.1f\" cy=\"%.1f\" r=\"8\" fill=\"#14aa28\"/><circle cx=\"%.1f\" cy=\"%.1f\" r=\"8\" "
                      "fill=\"#dc1e1e\"/>\n",
                   top.path.front().first, top.path.front().second, top.path.back().first, top.path.back().second);
    }
    std::fprintf(f, "</svg><div>grey: the map's surfels seen from above; magenta: the estimated path (green start, red "
                    "end)%s.</div>\n",
                 top.reference.size() >= 2 ? "; dashed blue: the source's reference path, aligned to it (the ATE's "
                                             "alignment)"
                                           : "");
  }

  // Rate over the run: frames per second between samples.
  std::fprintf(f, "<h2>Mapping rate over the run</h2>\n");
  if (in.rate.size() < 2) {
    std::fprintf(f, "<p>(the run was too short to sample its rate)</p>\n");
  } else {
    double max_fps = 1, t_end = in.rate.back().seconds;
    for (std::size_t i = 1; i < in.rate.size(); ++i) {
      const double dt = in.rate[i].seconds - in.rate[i - 1].seconds;
      if (dt > 0) max_fps = std::max(max_fps, static_cast<double>(in.rate[i].frames - in.rate[i - 1].frames) / dt);
    }
    const double W = 900, H = 220, L = 50, B = 30;
    std::fprintf(f, "<svg viewBox=\"0 0 %.0f %.0f\" width=\"900\" role=\"img\" aria-label=\"rate over time\">\n", W + L,
                 H + B);
    std::fprintf(f, "<line x1=\"%.0f\" y1=\"0\" x2=\"%.0f\" y2=\"%.0f\" stroke=\"#999\"/><line x1=\"%.0f\" y1=\"%.0f\" "
                    "x2=\"%.0f\" y2=\"%.0f\" stroke=\"#999\"/>\n",
                 L, L, H, L, H, W + L, H);
    std::fprintf(f, "<text x=\"4\" y=\"12\">%.0f fps</text><text x=\"4\" y=\"%.0f\">0</text><text x=\"%.0f\" "
                    "y=\"%.0f\">%.0f s</text>\n",
                 max_fps, H, W + L - 40, H + 20, t_end);
    std::fprintf(f, "<polyline fill=\"none\" stroke=\"#1f6fb4\" stroke-width=\"2\" points=\"");
    for (std::size_t i = 1; i < in.rate.size(); ++i) {
      const double dt = in.rate[i].seconds - in.rate[i - 1].seconds;
      if (dt <= 0) continue;
      const double r = static_cast<double>(in.rate[i].frames - in.rate[i - 1].frames) / dt;
      const double x = L + W * (0.5 * (in.rate[i].seconds + in.rate[i - 1].seconds)) / std::max(1e-9, t_end);
      std::fprintf(f, "%.1f,%.1f ", x, H - H * r / max_fps);
    }
    std::fprintf(f, "\"/></svg>\n");
  }

  // Stages and counters.
  if (in.stats != nullptr) {
    std::fprintf(f, "<h2>Stages</h2><table><tr><th>stage</th><th class=\"n\">frames</th><th class=\"n\">median ms</th>"
                    "<th class=\"n\">p95 ms</th><th class=\"n\">max ms</th></tr>\n");
    for (std::size_t i = 0; i < in.stats->num_stages(); ++i) {
      const StageSummary s = in.stats->summary(static_cast<int>(i));
      if (s.count == 0) continue;
      std::fprintf(f, "<tr><td>%s</td><td class=\"n\">%llu</td><td class=\"n\">%.3f</td><td class=\"n\">%.3f</td>"
                      "<td class=\"n\">%.3f</td></tr>\n",
                   esc(in.stats->stage_name(static_cast<int>(i))).c_str(), static_cast<unsigned long long>(s.count),
                   s.median_ms, s.p95_ms, s.max_ms);
    }
    std::fprintf(f, "</table>\n<h2>Counters</h2><table>\n");
    for (std::size_t i = 0; i < in.stats->num_counters(); ++i)
      std::fprintf(f, "<tr><td>%s</td><td class=\"n\">%llu</td></tr>\n",
                   esc(in.stats->counter_name(static_cast<int>(i))).c_str(),
                   static_cast<unsigned long long>(in.stats->counter(static_cast<int>(i))));
    std::fprintf(f, "</table>\n");
  }

  // The classes of the map.
  std::fprintf(f, "<h2>Classes of the map</h2>\n");
  int64_t total = 0;
  for (int64_t c : in.class_counts) total += c;
  if (total == 0) {
    std::fprintf(f, "<p>(no labels: the run mapped geometry only)</p>\n");
  } else {
    std::fprintf(f, "<table>\n");
    for (int c = 0; c < static_cast<int>(in.class_counts.size()) && c < kNumClassesWithUnknown; ++c) {
      if (in.class_counts[c] == 0) continue;
      const Rgb8 col = class_color(c);
      const double share = 100.0 * static_cast<double>(in.class_counts[c]) / static_cast<double>(total);
      std::fprintf(f, "<tr><td><span class=\"sw\" style=\"background:rgb(%d,%d,%d)\"></span>%s</td><td class=\"n\">%lld"
                      "</td><td class=\"n\">%.1f%%</td><td><svg width=\"300\" height=\"12\"><rect width=\"%.1f\" "
                      "height=\"12\" fill=\"rgb(%d,%d,%d)\" stroke=\"#999\"/></svg></td></tr>\n",
                   col.r, col.g, col.b, std::string(class_name(c)).c_str(), static_cast<long long>(in.class_counts[c]),
                   share, 3.0 * share, col.r, col.g, col.b);
    }
    std::fprintf(f, "</table>\n");
  }

  std::fprintf(f, "<h2>Configuration</h2><pre>%s</pre>\n</body></html>\n", esc(in.config_text).c_str());
  const bool write_failed = std::ferror(f) != 0;
  if (std::fclose(f) != 0 || write_failed) return error(ErrorCode::kIoError, path + ": write failed: " + std::strerror(errno));
  return file.commit();
}

}  // namespace ef::pipeline
