#include "pipeline/map_preview.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>

#include <Eigen/Eigenvalues>
#include <opencv2/imgproc.hpp>

#include "core/classes.h"
#include "io/durable_file.h"
#include "io/image_codec.h"
#include "io/png_encoder.h"

namespace ef::pipeline {

namespace {

constexpr int kLegendRowPx = 26;      // one row of the legend
constexpr int kMaxSplatPx = 10;       // largest disc radius drawn, pixels (a surfel next to the camera)
constexpr double kElevationDeg = 35;  // the oblique view looks down this much
constexpr int kSamples = 20000;       // surfel centres sampled for the framing percentiles

const Rgb8 kBackground{246, 246, 246};
const Rgb8 kUnknownClass{64, 64, 64};  // the palette's black, lifted so that shading still shows the shape

Eigen::Vector3d centre_of(const SurfelCloudView& c, std::size_t i) { return {c.x[i], c.y[i], c.z[i]}; }

// The value at fraction q (0..1) of the sorted values; reorders `v` (the values stay the same, so
// another quantile of it after this one is the same as of the original order).
double quantile(std::vector<double>& v, double q) {
  const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

// A unit vector perpendicular to `u`.
Eigen::Vector3d any_perpendicular(const Eigen::Vector3d& u) {
  const Eigen::Vector3d a = std::abs(u.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  return u.cross(a).normalized();
}

// Camera looking from `eye` toward `target` with world direction `up` up in the image
// (camera axes: x right, y down, z forward).
SE3 look_at(const Eigen::Vector3d& eye, const Eigen::Vector3d& target, const Eigen::Vector3d& up) {
  const Eigen::Vector3d z = (target - eye).normalized();
  Eigen::Vector3d x = z.cross(up);
  if (x.norm() < 1e-6) x = any_perpendicular(z);
  x.normalize();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d R;
  R.col(0) = x;
  R.col(1) = y;
  R.col(2) = z;
  return SE3(R, eye);
}

Rgb8 shade(Rgb8 c, float s) {
  auto f = [s](uint8_t v) { return static_cast<uint8_t>(std::min(255.0f, static_cast<float>(v) * s + 0.5f)); };
  return Rgb8{f(c.r), f(c.g), f(c.b)};
}

cv::Mat as_mat(ImageView<Rgb8> v) { return cv::Mat(v.height, v.width, CV_8UC3, v.data, v.stride_bytes); }

// A stroke from a to b, `half` pixels either side, round ends, its edge smoothed over a pixel.
// Ours rather than OpenCV's: cv::polylines with thick anti-aliased lines allocates for every
// segment's caps (some 3000 blocks for a path of a hundred points), and the preview is drawn at
// every checkpoint on the mapping thread.
void draw_stroke(ImageView<Rgb8> img, cv::Point2f a, cv::Point2f b, float half, Rgb8 colour) {
  const int x0 = std::max(0, static_cast<int>(std::floor(std::min(a.x, b.x) - half - 1)));
  const int x1 = std::min(img.width - 1, static_cast<int>(std::ceil(std::max(a.x, b.x) + half + 1)));
  const int y0 = std::max(0, static_cast<int>(std::floor(std::min(a.y, b.y) - half - 1)));
  const int y1 = std::min(img.height - 1, static_cast<int>(std::ceil(std::max(a.y, b.y) + half + 1)));
  const float dx = b.x - a.x, dy = b.y - a.y, len2 = dx * dx + dy * dy;
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      // Distance from the pixel to the segment.
      float t = len2 > 0 ? ((static_cast<float>(x) - a.x) * dx + (static_cast<float>(y) - a.y) * dy) / len2 : 0.0f;
      t = std::min(1.0f, std::max(0.0f, t));
      const float ex = static_cast<float>(x) - (a.x + t * dx), ey = static_cast<float>(y) - (a.y + t * dy);
      const float cover = std::min(1.0f, std::max(0.0f, half + 0.5f - std::sqrt(ex * ex + ey * ey)));
      if (cover <= 0) continue;
      Rgb8& p = img(x, y);
      auto mix = [cover](uint8_t under, uint8_t over) {
        return static_cast<uint8_t>(static_cast<float>(under) + cover * (static_cast<float>(over) - under) + 0.5f);
      };
      p = Rgb8{mix(p.r, colour.r), mix(p.g, colour.g), mix(p.b, colour.b)};
    }
}

// A filled disc (a stroke of no length).
void draw_dot(ImageView<Rgb8> img, cv::Point2f c, float radius, Rgb8 colour) { draw_stroke(img, c, c, radius, colour); }

// Classes per legend row, and the legend's height, for panels `w` wide with `classes` present.
int legend_per_row(int w) { return std::max(1, (2 * w) / 200); }
int picture_height(int w, int h, int classes) {
  const int rows = 1 + (classes + legend_per_row(w) - 1) / legend_per_row(w);
  return h + rows * kLegendRowPx + 6;
}

}  // namespace

// The sample columns frame_map sorts, reserved once (kSamples each).
struct MapPreviewer::Framing {
  std::vector<double> xs, ys, zs, us, vs;
  Framing() {
    for (std::vector<double>* v : {&xs, &ys, &zs, &us, &vs}) v->reserve(kSamples);
  }
};

namespace {

PreviewCamera frame_map_with(const SurfelCloudView& cloud, const std::vector<SE3>& trajectory, const PreviewOptions& o,
                             MapPreviewer::Framing& fr);

}  // namespace

PreviewCamera frame_map(const SurfelCloudView& cloud, const std::vector<SE3>& trajectory, const PreviewOptions& o) {
  MapPreviewer::Framing fr;
  return frame_map_with(cloud, trajectory, o, fr);
}

namespace {

PreviewCamera frame_map_with(const SurfelCloudView& cloud, const std::vector<SE3>& trajectory, const PreviewOptions& o,
                             MapPreviewer::Framing& fr) {
  PreviewCamera cam;
  const int w = o.width, h = o.height;
  // A 60-degree horizontal field of view unless given.
  const float f = static_cast<float>(0.5 * w / std::tan(30.0 * M_PI / 180.0));
  cam.intrinsics = o.intrinsics ? *o.intrinsics
                                : Intrinsics{f, f, 0.5f * static_cast<float>(w - 1), 0.5f * static_cast<float>(h - 1), w, h};
  if (o.pose) {
    cam.T_world_cam = *o.pose;
    return cam;
  }
  // Up and the mostly-looked direction from the trajectory (camera x right, y down, z forward). A
  // hand-held or robot camera pitches (looks down at a table) but hardly rolls: its x axis stays
  // horizontal, so up is the direction most nearly perpendicular to every x axis (the smallest
  // eigenvector of their scatter), on the side of the cameras' mean -y.
  Eigen::Vector3d up(0, -1, 0), forward(0, 0, 1);
  if (!trajectory.empty()) {
    Eigen::Vector3d su = Eigen::Vector3d::Zero(), sf = Eigen::Vector3d::Zero();
    Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
    for (const SE3& T : trajectory) {
      const Eigen::Matrix3d R = T.rotation().toRotationMatrix();
      su -= R.col(1);
      sf += R.col(2);
      scatter += R.col(0) * R.col(0).transpose();
    }
    if (su.norm() > 1e-9) up = su.normalized();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(scatter);
    // Only when the x axes pin a plane (the camera turned about its up axis); a camera that never
    // turned leaves the mean up.
    if (eig.info() == Eigen::Success && eig.eigenvalues()(1) > 0.05 * static_cast<double>(trajectory.size())) {
      Eigen::Vector3d normal = eig.eigenvectors().col(0);
      up = normal.dot(up) < 0 ? -normal : normal;
    }
    forward = sf;
  }
  forward -= forward.dot(up) * up;  // horizontal
  forward = forward.norm() > 1e-6 ? forward.normalized() : any_perpendicular(up);

  // The extent: percentiles of a sample of the centres.
  const std::size_t n = cloud.count;
  const std::size_t step = std::max<std::size_t>(1, (n + kSamples - 1) / kSamples);  // at most kSamples
  std::vector<double>&xs = fr.xs, &ys = fr.ys, &zs = fr.zs;
  xs.clear(), ys.clear(), zs.clear();
  for (std::size_t i = 0; i < n; i += step) {
    xs.push_back(cloud.x[i]);
    ys.push_back(cloud.y[i]);
    zs.push_back(cloud.z[i]);
  }
  // The camera's path is in the picture too (a few of its poses count like surfels).
  const std::size_t path_step = std::max<std::size_t>(1, trajectory.size() / 200);
  const Eigen::Vector3d lo(quantile(xs, 0.02), quantile(ys, 0.02), quantile(zs, 0.02));
  const Eigen::Vector3d hi(quantile(xs, 0.98), quantile(ys, 0.98), quantile(zs, 0.98));
  const Eigen::Vector3d centre = 0.5 * (lo + hi);
  const double radius = std::max(0.25, 0.5 * (hi - lo).norm());

  const double half_fov = std::atan(0.5 * std::min(w / cam.intrinsics.fx, h / cam.intrinsics.fy));
  const double distance = radius / std::sin(half_fov);
  if (o.top) {
    // Straight down, the mostly-looked direction up in the image.
    cam.T_world_cam = look_at(centre + up * distance, centre, forward);
  } else {
    const double e = kElevationDeg * M_PI / 180.0;
    const Eigen::Vector3d eye = centre - forward * (distance * std::cos(e)) + up * (distance * std::sin(e));
    cam.T_world_cam = look_at(eye, centre, up);
  }
  // Fill the image: scale the focal length and move the principal point so that the projected
  // 2..98% extent of the sampled centres spans 92% of it (same perspective, tighter frame).
  const SE3 T_cam_world = cam.T_world_cam.inverse();
  std::vector<double>&us = fr.us, &vs = fr.vs;
  us.clear(), vs.clear();
  for (std::size_t i = 0; i < n; i += step) {
    const Eigen::Vector3d p = T_cam_world * centre_of(cloud, i);
    if (p.z() <= 1e-3) continue;
    us.push_back(p.x() / p.z());
    vs.push_back(p.y() / p.z());
  }
  double pu0 = 1e9, pu1 = -1e9, pv0 = 1e9, pv1 = -1e9;  // the path's whole extent (no percentile)
  for (std::size_t i = 0; i < trajectory.size(); i += path_step) {
    const Eigen::Vector3d p = T_cam_world * trajectory[i].translation();
    if (p.z() <= 1e-3) continue;
    pu0 = std::min(pu0, p.x() / p.z());
    pu1 = std::max(pu1, p.x() / p.z());
    pv0 = std::min(pv0, p.y() / p.z());
    pv1 = std::max(pv1, p.y() / p.z());
  }
  if (us.size() >= 8) {
    const double u0 = std::min(quantile(us, 0.02), pu0), u1 = std::max(quantile(us, 0.98), pu1);
    const double v0 = std::min(quantile(vs, 0.02), pv0), v1 = std::max(quantile(vs, 0.98), pv1);
    const double fit = std::min(0.92 * w / std::max(1e-6, u1 - u0), 0.92 * h / std::max(1e-6, v1 - v0));
    cam.intrinsics.fx = cam.intrinsics.fy = static_cast<float>(fit);
    cam.intrinsics.cx = static_cast<float>(0.5 * (w - 1) - fit * 0.5 * (u0 + u1));
    cam.intrinsics.cy = static_cast<float>(0.5 * (h - 1) - fit * 0.5 * (v0 + v1));
  }
  return cam;
}

}  // namespace

MapPreviewer::MapPreviewer(int width, int height)
    : width_(width),
      height_(height),
      depth_(static_cast<std::size_t>(width) * height),
      light_(static_cast<std::size_t>(width) * height),
      owner_(static_cast<std::size_t>(width) * height),
      picture_(2 * width, picture_height(width, height, kNumClassesWithUnknown)),
      framing_(std::make_unique<Framing>()),
      png_(std::make_unique<PngEncoder>(2 * width, picture_height(width, height, kNumClassesWithUnknown), 3,
                                        /*level=*/1)) {
  path_px_.reserve(kPreviewPathPoses);
  png_bytes_.reserve(PngEncoder::bytes_for(picture_.width(), picture_.height(), 3));
}

MapPreviewer::~MapPreviewer() = default;

Result<std::unique_ptr<MapPreviewer>> MapPreviewer::create(int width, int height) {
  if (width < 64 || height < 64 || width > 4096 || height > 4096)
    return error(ErrorCode::kInvalidArgument, "preview size " + std::to_string(width) + "x" + std::to_string(height) +
                                                  " is outside 64x64..4096x4096");
  return std::unique_ptr<MapPreviewer>(new MapPreviewer(width, height));
}

Result<ImageView<const Rgb8>> MapPreviewer::render(const SurfelCloudView& cloud, const std::vector<SE3>& trajectory,
                                                   const PreviewOptions& options, PreviewStats* stats) {
  if (cloud.count == 0) return error(ErrorCode::kInvalidArgument, "the map has no surfels to draw");
  PreviewOptions o = options;
  o.width = width_;
  o.height = height_;
  const PreviewCamera cam = frame_map_with(cloud, trajectory, o, *framing_);
  const Intrinsics& k = cam.intrinsics;
  const SE3 T_cw = cam.T_world_cam.inverse();
  const Eigen::Matrix3f R = T_cw.rotation().toRotationMatrix().cast<float>();
  const Eigen::Vector3f t = T_cw.translation().cast<float>();
  const int w = width_, h = height_;

  // One depth buffer, the winning surfel per pixel, and its shading.
  std::fill(depth_.begin(), depth_.end(), std::numeric_limits<float>::infinity());
  std::fill(owner_.begin(), owner_.end(), -1);
  std::fill(light_.begin(), light_.end(), 1.0f);
  std::vector<float>& depth = depth_;
  std::vector<int32_t>& owner = owner_;
  std::vector<float>& light = light_;
  PreviewStats st;
  st.surfels = static_cast<int64_t>(cloud.count);
  const bool has_classes = cloud.class_id.data != nullptr;
  for (std::size_t i = 0; i < cloud.count; ++i) {
    if (has_classes && cloud.class_id[i] < kNumClassesWithUnknown) ++st.class_counts[cloud.class_id[i]];
    const Eigen::Vector3f p = R * Eigen::Vector3f(cloud.x[i], cloud.y[i], cloud.z[i]) + t;
    if (!(p.z() > 0.05f)) continue;
    const float u = k.fx * p.x() / p.z() + k.cx, v = k.fy * p.y() / p.z() + k.cy;
    // Far outside the picture (a surfel next to the camera's plane): skipped before any conversion
    // to int, which would overflow.
    if (!(std::abs(u) < 1e6f && std::abs(v) < 1e6f)) continue;
    const float radius = cloud.radius.data != nullptr ? cloud.radius[i] : 0.0f;
    const float r = std::min(static_cast<float>(kMaxSplatPx), std::max(0.75f, k.fx * radius / p.z()));
    const int x0 = std::max(0, static_cast<int>(std::floor(u - r))), x1 = std::min(w - 1, static_cast<int>(std::ceil(u + r)));
    const int y0 = std::max(0, static_cast<int>(std::floor(v - r))), y1 = std::min(h - 1, static_cast<int>(std::ceil(v + r)));
    if (x0 > x1 || y0 > y1) continue;
    ++st.drawn;
    // Headlight shading: a surface facing the camera is bright, a grazing one darker.
    float s = 1.0f;
    if (cloud.nx.data != nullptr) {
      const Eigen::Vector3f nrm = R * Eigen::Vector3f(cloud.nx[i], cloud.ny[i], cloud.nz[i]);
      const float facing = std::abs(nrm.dot(p.normalized()));
      s = 0.45f + 0.6f * facing;
    }
    const float r2 = r * r;
    for (int y = y0; y <= y1; ++y) {
      const float dy = static_cast<float>(y) - v;
      for (int x = x0; x <= x1; ++x) {
        const float dx = static_cast<float>(x) - u;
        if (dx * dx + dy * dy > r2) continue;
        const std::size_t at = static_cast<std::size_t>(y) * w + x;
        if (p.z() < depth[at]) {
          depth[at] = p.z();
          owner[at] = static_cast<int32_t>(i);
          light[at] = s;
        }
      }
    }
  }

  // The legend's rows: the classes present, most surfels first, four to a row.
  std::array<int, kNumClassesWithUnknown> present{};
  int n_present = 0;
  if (has_classes)
    for (int c = 0; c < kNumClassesWithUnknown; ++c)
      if (st.class_counts[c] > 0) present[n_present++] = c;
  std::stable_sort(present.begin(), present.begin() + n_present,
                   [&](int a, int b) { return st.class_counts[a] > st.class_counts[b]; });
  const int per_row = legend_per_row(w);
  ImageView<Rgb8> picture = picture_.view().sub(0, 0, 2 * w, picture_height(w, h, n_present));
  for (int y = 0; y < picture.height; ++y)
    for (int x = 0; x < picture.width; ++x) picture(x, y) = kBackground;
  ImageView<Rgb8> colour = picture.sub(0, 0, w, h), labels = picture.sub(w, 0, w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const std::size_t at = static_cast<std::size_t>(y) * w + x;
      const int32_t i = owner[at];
      if (i < 0) continue;
      ++st.covered_pixels;
      colour(x, y) = shade(Rgb8{cloud.red[static_cast<std::size_t>(i)], cloud.green[static_cast<std::size_t>(i)],
                                cloud.blue[static_cast<std::size_t>(i)]},
                           light[at]);
      const int c = has_classes ? cloud.class_id[static_cast<std::size_t>(i)] : 0;
      labels(x, y) = shade(c == 0 || c >= kNumClassesWithUnknown ? kUnknownClass : class_color(c), light[at]);
    }

  // The camera's path over both panels.
  cv::Mat all = as_mat(picture);
  std::vector<cv::Point2f>& path = path_px_;
  path.clear();
  for (const SE3& T : trajectory) {
    const Eigen::Vector3d p = T_cw * T.translation();
    if (p.z() <= 0.05) continue;
    const double pu = k.fx * p.x() / p.z() + k.cx, pv = k.fy * p.y() / p.z() + k.cy;
    if (!(std::abs(pu) < 1e6 && std::abs(pv) < 1e6)) continue;  // far outside: no int overflow
    path.emplace_back(static_cast<float>(pu), static_cast<float>(pv));
  }
  const Rgb8 kStart{20, 170, 40}, kEnd{220, 30, 30}, kHalo{255, 255, 255}, kPath{200, 30, 160};
  for (int panel = 0; panel < 2; ++panel) {
    ImageView<Rgb8> m = panel == 0 ? colour : labels;
    for (std::size_t i = 1; i < path.size(); ++i) draw_stroke(m, path[i - 1], path[i], 2.0f, kHalo);
    for (std::size_t i = 1; i < path.size(); ++i) draw_stroke(m, path[i - 1], path[i], 1.0f, kPath);
    if (!path.empty()) {
      draw_dot(m, path.front(), 6.0f, kStart);
      draw_dot(m, path.back(), 6.0f, kEnd);
    }
    cv::Mat mat = as_mat(m);
    const char* heading = panel == 0 ? "colour" : (has_classes ? "labels (NYUv2 13 classes)" : "labels: none in this map");
    cv::putText(mat, heading, cv::Point(10, h - 12), cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(40, 40, 40), 1, cv::LINE_AA);
  }
  if (!o.title.empty())
    cv::putText(all, o.title, cv::Point(10, 22), cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar(40, 40, 40), 1, cv::LINE_AA);
  cv::line(all, cv::Point(w, 0), cv::Point(w, h - 1), cv::Scalar(200, 200, 200), 1);

  // Legend: path markers, then each class present with its share of the surfels.
  int y = h + 6;
  char text[96];
  draw_dot(picture, cv::Point2f(16, static_cast<float>(y + 12)), 6.0f, kStart);
  cv::putText(all, "start", cv::Point(28, y + 17), cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(40, 40, 40), 1, cv::LINE_AA);
  draw_dot(picture, cv::Point2f(96, static_cast<float>(y + 12)), 6.0f, kEnd);
  std::snprintf(text, sizeof text, "end of the camera path; %lld surfels, %.0f%% of the panel covered",
                static_cast<long long>(st.surfels), 100.0 * static_cast<double>(st.covered_pixels) / (double(w) * h));
  cv::putText(all, text, cv::Point(108, y + 17), cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(40, 40, 40), 1, cv::LINE_AA);
  for (int j = 0; j < n_present; ++j) {
    const int c = present[j];
    const int row = 1 + static_cast<int>(j) / per_row, col = static_cast<int>(j) % per_row;
    const int x = 10 + col * 200, yy = y + row * kLegendRowPx;
    const Rgb8 sw = c == 0 ? kUnknownClass : class_color(c);
    cv::rectangle(all, cv::Rect(x, yy + 4, 16, 16), cv::Scalar(sw.r, sw.g, sw.b), cv::FILLED);
    const std::string_view name = class_name(c);
    std::snprintf(text, sizeof text, "%.*s %.1f%%", static_cast<int>(name.size()), name.data(),
                  100.0 * static_cast<double>(st.class_counts[c]) / static_cast<double>(st.surfels));
    cv::putText(all, text, cv::Point(x + 22, yy + 17), cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(40, 40, 40), 1,
                cv::LINE_AA);
  }
  if (stats != nullptr) *stats = st;
  return ImageView<const Rgb8>(picture);
}

Status MapPreviewer::write(const std::string& path, const SurfelCloudView& cloud, const std::vector<SE3>& trajectory,
                           const PreviewOptions& options, PreviewStats* stats) {
  auto image = render(cloud, trajectory, options, stats);
  if (!image.ok()) return error(image.error().code, path + ": " + image.error().message);
  if (Status s = png_->encode(*image, png_bytes_); !s.ok()) return error(s.error().code, path + ": " + s.error().message);
  return write_file_whole(path, {{png_bytes_.data(), png_bytes_.size()}});
}

Result<Image<Rgb8>> render_map_preview(const SurfelCloudView& cloud, const std::vector<SE3>& trajectory,
                                       const PreviewOptions& o, PreviewStats* stats) {
  auto previewer = MapPreviewer::create(o.width, o.height);
  if (!previewer.ok()) return previewer.error();
  auto view = (*previewer)->render(cloud, trajectory, o, stats);
  if (!view.ok()) return view.error();
  Image<Rgb8> image(view->width, view->height);
  for (int y = 0; y < view->height; ++y)
    for (int x = 0; x < view->width; ++x) image.view()(x, y) = (*view)(x, y);
  return image;
}


Result<std::vector<SE3>> read_preview_path(const std::string& tum_file, std::size_t max_poses) {
  PreviewPath path(max_poses);
  EF_RETURN_IF_ERROR(path.add_file(tum_file));
  return path.poses();
}

std::size_t map_preview_bytes_for(int width, int height) {
  const std::size_t pixels = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  const int picture_w = 2 * width, picture_h = picture_height(width, height, kNumClassesWithUnknown);
  const std::size_t picture = static_cast<std::size_t>(picture_w) * static_cast<std::size_t>(picture_h) * sizeof(Rgb8);
  constexpr std::size_t kZlibState = 256 * 1024;  // deflate's window and hash tables at the default settings
  return pixels * (sizeof(float) * 2 + sizeof(int32_t))                          // depth, light, owner
         + picture                                                                // the picture
         + 5 * kSamples * sizeof(double)                                          // framing samples
         + kPreviewPathPoses * sizeof(cv::Point2f) + PreviewPath::bytes_for(kPreviewPathPoses)  // the path
         + PngEncoder::bytes_for(picture_w, picture_h, 3) + 2 * static_cast<std::size_t>(picture_w) * 3 + kZlibState;
}

Status write_map_preview(const std::string& path, const SurfelCloudView& cloud, const std::vector<SE3>& trajectory,
                         const PreviewOptions& options, PreviewStats* stats) {
  auto previewer = MapPreviewer::create(options.width, options.height);
  if (!previewer.ok()) return error(previewer.error().code, path + ": " + previewer.error().message);
  return (*previewer)->write(path, cloud, trajectory, options, stats);
}

void PreviewPath::reserve(std::size_t capacity) {
  capacity_ = rounded_capacity(capacity);
  poses_.clear();
  poses_.reserve(capacity_);
  stride_ = 1;
  seen_ = 0;
}

void PreviewPath::add(const SE3& T_world_cam) {
  if (capacity_ == 0 || seen_++ % stride_ != 0) return;
  if (poses_.size() == capacity_) {  // full: keep every other, take every 2k-th from now on
    std::size_t k = 0;
    for (std::size_t j = 0; j < poses_.size(); j += 2) poses_[k++] = poses_[j];
    poses_.resize(k);
    stride_ *= 2;
  }
  poses_.push_back(T_world_cam);
}

Status PreviewPath::add_file(const std::string& tum_file) {
  std::ifstream in(tum_file);
  if (!in) return error(ErrorCode::kNotFound, tum_file + ": cannot open the trajectory");
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream f(line);
    double t, tx, ty, tz, qx, qy, qz, qw;
    if (!(f >> t >> tx >> ty >> tz >> qx >> qy >> qz >> qw)) continue;  // not a pose line
    add(SE3(Eigen::Quaterniond(qw, qx, qy, qz), Eigen::Vector3d(tx, ty, tz)));
  }
  return Status::success();
}

}  // namespace ef::pipeline
