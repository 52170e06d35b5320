// The map's picture (pipeline/map_preview.h): its framing, its up direction from a real-looking
// camera path, the two panels drawn from one viewpoint, the legend's counts, the path's bounded
// reading, and its errors.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <string>
#include <vector>

#include "core/classes.h"
#include "io/image_codec.h"
#include "pipeline/map_preview.h"
#include "support/alloc_counter.h"
#include "test_support.h"

namespace ef::pipeline {
namespace {

// A room-sized scene: a floor of 2 x 3 m at y = +1 (the first camera's y points down) and a table
// top 0.7 m above it, as owned columns.
struct Scene {
  std::vector<float> x, y, z, nx, ny, nz, radius, conf, prob;
  std::vector<uint8_t> r, g, b, cls;
  void add(float px, float py, float pz, uint8_t c) {
    x.push_back(px);
    y.push_back(py);
    z.push_back(pz);
    nx.push_back(0);
    ny.push_back(-1);
    nz.push_back(0);
    radius.push_back(0.012f);
    conf.push_back(20);
    prob.push_back(0.9f);
    const Rgb8 col = class_color(c);
    r.push_back(col.r);
    g.push_back(col.g);
    b.push_back(col.b);
    cls.push_back(c);
  }
  SurfelCloudView view() const {
    SurfelCloudView v;
    v.count = x.size();
    v.x = x.data(), v.y = y.data(), v.z = z.data();
    v.nx = nx.data(), v.ny = ny.data(), v.nz = nz.data();
    v.red = r.data(), v.green = g.data(), v.blue = b.data();
    v.radius = radius.data(), v.confidence = conf.data();
    v.class_id = cls.data(), v.class_prob = prob.data();
    return v;
  }
};

Scene room() {
  Scene s;
  for (float px = -1.0f; px <= 1.0f; px += 0.02f)
    for (float pz = 1.0f; pz <= 4.0f; pz += 0.02f) s.add(px, 1.0f, pz, kFloor);
  for (float px = -0.4f; px <= 0.4f; px += 0.02f)
    for (float pz = 2.0f; pz <= 2.8f; pz += 0.02f) s.add(px, 0.3f, pz, kTable);
  return s;
}

// A camera walking across the room at 1.5 m height, looking ahead and 30 degrees down, turning
// about the room's up axis; the whole path turned by `tilt` about x (a world frame whose axes are
// not the room's).
std::vector<SE3> walk(double tilt_rad) {
  std::vector<SE3> path;
  const Eigen::Matrix3d world = Eigen::AngleAxisd(tilt_rad, Eigen::Vector3d::UnitX()).toRotationMatrix();
  for (int i = 0; i < 100; ++i) {
    const double yaw = -0.8 + 1.6 * i / 99.0;
    const Eigen::Matrix3d R = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()).toRotationMatrix() *
                              Eigen::AngleAxisd(-30.0 * M_PI / 180.0, Eigen::Vector3d::UnitX()).toRotationMatrix();
    const Eigen::Vector3d t(-0.8 + 1.6 * i / 99.0, -0.5, 0.5);
    path.emplace_back(world * R, world * t);
  }
  return path;
}

TEST(MapPreview, FramesTheMapInsideThePanel) {
  const Scene s = room();
  const SurfelCloudView v = s.view();
  for (bool top : {false, true}) {
    PreviewOptions o;
    o.top = top;
    const PreviewCamera cam = frame_map(v, walk(0), o);
    const SE3 T_cw = cam.T_world_cam.inverse();
    std::size_t inside = 0;
    for (std::size_t i = 0; i < v.count; ++i) {
      const Eigen::Vector3d p = T_cw * Eigen::Vector3d(v.x[i], v.y[i], v.z[i]);
      const double u = cam.intrinsics.fx * p.x() / p.z() + cam.intrinsics.cx;
      const double w = cam.intrinsics.fy * p.y() / p.z() + cam.intrinsics.cy;
      inside += p.z() > 0 && u >= 0 && u < o.width && w >= 0 && w < o.height;
    }
    EXPECT_GE(inside, v.count * 95 / 100) << (top ? "top" : "oblique");
    // ...and fills it: what is drawn spans most of the panel's width or height.
    auto img = render_map_preview(v, {}, o);
    ASSERT_TRUE(img.ok()) << to_string(img.error());
    int x0 = o.width, x1 = -1, y0 = o.height, y1 = -1;
    const Rgb8 bg{246, 246, 246};
    for (int y = 30; y < o.height - 30; ++y)  // below the title, above the caption
      for (int x = 0; x < o.width; ++x)
        if (img->view()(x, y) != bg) x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
    EXPECT_TRUE(x1 - x0 > o.width * 8 / 10 || y1 - y0 > (o.height - 60) * 8 / 10)
        << (top ? "top" : "oblique") << ": drawn in x " << x0 << ".." << x1 << ", y " << y0 << ".." << y1;
  }
}

// Up comes from the camera path, not from the world's axes: with the whole scene tilted by 40
// degrees the top view still looks straight down the room's up axis (the cameras pitch 30 degrees
// down, which the mean of their up axes would take for the vertical).
TEST(MapPreview, TopViewLooksAlongTheRoomsUpAxis) {
  for (double tilt_deg : {0.0, 40.0}) {
    const Eigen::Matrix3d world = Eigen::AngleAxisd(tilt_deg * M_PI / 180.0, Eigen::Vector3d::UnitX()).toRotationMatrix();
    Scene s = room();
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      const Eigen::Vector3d p = world * Eigen::Vector3d(s.x[i], s.y[i], s.z[i]);
      s.x[i] = float(p.x()), s.y[i] = float(p.y()), s.z[i] = float(p.z());
    }
    PreviewOptions o;
    o.top = true;
    const PreviewCamera cam = frame_map(s.view(), walk(tilt_deg * M_PI / 180.0), o);
    const Eigen::Vector3d look = cam.T_world_cam.rotation() * Eigen::Vector3d::UnitZ();
    const Eigen::Vector3d down = world * Eigen::Vector3d::UnitY();  // the room's down (camera y)
    EXPECT_GT(look.dot(down), std::cos(2.0 * M_PI / 180.0)) << "tilt " << tilt_deg << ": looks along " << look.transpose();
  }
}

TEST(MapPreview, BothPanelsShowTheSameSurfelsAndTheLegendCountsThem) {
  const Scene s = room();
  PreviewOptions o;
  o.width = 320;
  o.height = 240;
  PreviewStats st;
  auto img = render_map_preview(s.view(), {}, o, &st);  // no path drawn over the panels
  ASSERT_TRUE(img.ok()) << to_string(img.error());
  EXPECT_EQ(img->width(), 2 * o.width);
  EXPECT_GT(img->height(), o.height);
  int64_t floor = 0, table = 0;
  for (uint8_t c : s.cls) (c == kFloor ? floor : table) += 1;
  EXPECT_EQ(st.class_counts[kFloor], floor);
  EXPECT_EQ(st.class_counts[kTable], table);
  EXPECT_EQ(st.surfels, static_cast<int64_t>(s.x.size()));
  // One viewpoint: a pixel is drawn in the colour panel exactly where it is in the labels panel
  // (away from the path and the captions drawn over them), and there the label is the palette's
  // colour of floor or table, shaded (each channel a common factor of the palette's).
  const Rgb8 bg{246, 246, 246};
  int mismatched = 0, drawn = 0, off_palette = 0;
  for (int y = 30; y < o.height - 30; ++y)
    for (int x = 0; x < o.width; ++x) {
      const Rgb8 a = img->view()(x, y), b = img->view()(x + o.width, y);
      mismatched += (a == bg) != (b == bg);
      if (b == bg) continue;
      ++drawn;
      bool fits = false;
      for (int c : {int(kFloor), int(kTable)}) {
        const Rgb8 p = class_color(c);
        const double k = double(b.r + b.g + b.b) / double(p.r + p.g + p.b);
        fits = fits || (std::abs(b.r - k * p.r) < 6 && std::abs(b.g - k * p.g) < 6 && std::abs(b.b - k * p.b) < 6);
      }
      off_palette += !fits;
    }
  EXPECT_GT(drawn, 1000);
  EXPECT_LT(mismatched, drawn / 50) << "the panels disagree on what is drawn";
  EXPECT_LT(off_palette, drawn / 20) << "label pixels not in the palette's colours";
}

TEST(MapPreview, TheNearerSurfelHidesTheFartherOne) {
  Scene s;
  // Two parallel walls facing the camera at z = 2 (chair) and z = 3 (wall), the near one smaller.
  for (float px = -0.3f; px <= 0.3f; px += 0.01f)
    for (float py = -0.3f; py <= 0.3f; py += 0.01f) s.add(px, py, 2.0f, kChair);
  for (float px = -1.0f; px <= 1.0f; px += 0.02f)
    for (float py = -1.0f; py <= 1.0f; py += 0.02f) s.add(px, py, 3.0f, kWall);
  // And one next to the camera's plane, far to the side: it projects millions of pixels out, and is
  // skipped (no int overflow: UBSan in CI).
  s.add(1.0e7f, 0.0f, 0.06f, kWall);
  PreviewOptions o;
  o.width = o.height = 200;
  o.pose = SE3();  // at the origin, looking down +z
  auto img = render_map_preview(s.view(), {SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(1e7, 0, 0.06))}, o);
  ASSERT_TRUE(img.ok()) << to_string(img.error());
  const Rgb8 centre = img->view()(o.width + 100, 100), side = img->view()(o.width + 100 + 80, 100);
  const Rgb8 chair = class_color(kChair), wall = class_color(kWall);
  auto close_hue = [](Rgb8 a, Rgb8 p) {
    const double k = double(a.r + a.g + a.b + 1) / double(p.r + p.g + p.b + 1);
    return std::abs(a.r - k * p.r) < 8 && std::abs(a.g - k * p.g) < 8 && std::abs(a.b - k * p.b) < 8;
  };
  EXPECT_TRUE(close_hue(centre, chair)) << int(centre.r) << " " << int(centre.g) << " " << int(centre.b);
  EXPECT_TRUE(close_hue(side, wall)) << int(side.r) << " " << int(side.g) << " " << int(side.b);
}

TEST(MapPreview, PathOfALongRunIsReadBoundedAndEvenlySpaced) {
  const auto dir = test::scratch_dir("map-preview-path");
  const auto file = dir / "trajectory.txt";
  {
    std::ofstream f(file);
    f << "# timestamp tx ty tz qx qy qz qw\n";
    for (int i = 0; i < 10000; ++i) {
      if (i == 5) f << "# lost 0.1 diverged\n";
      f << i * 0.033 << " " << i * 0.001 << " 0 0 0 0 0 1\n";
    }
  }
  auto path = read_preview_path(file.string(), 1000);
  ASSERT_TRUE(path.ok()) << to_string(path.error());
  EXPECT_LE(path->size(), 1000u);
  EXPECT_GE(path->size(), 500u);
  EXPECT_DOUBLE_EQ(path->front().translation().x(), 0.0);
  // Evenly spaced: every step the same (the stride that the file's length made).
  const double step = (*path)[1].translation().x() - (*path)[0].translation().x();
  for (std::size_t i = 1; i < path->size(); ++i)
    EXPECT_NEAR((*path)[i].translation().x() - (*path)[i - 1].translation().x(), step, 1e-9) << i;
  EXPECT_GT(path->back().translation().x(), 9.0) << "the path reaches the end of the run";
  EXPECT_FALSE(read_preview_path((dir / "none.txt").string()).ok());
}

// A run draws its preview at every checkpoint with the previewer it made at start-up: drawing
// again allocates only OpenCV's text drawing (a 16 kB point buffer per string, freed at once; no
// image, depth buffer, sample column or path: those are 2.3 + 3.7 MB at a run's 640x480 panels),
// and draws the same picture each time, the one render_map_preview draws.
TEST(MapPreview, APreviewerDrawsAgainWithoutLargeAllocations) {
  ASSERT_TRUE(test::allocation_counting_enabled());
  const Scene s = room();
  const std::vector<SE3> path = walk(0.0);
  PreviewOptions o;
  o.width = 320;
  o.height = 240;
  o.title = "a room, 100 frames";
  auto previewer = MapPreviewer::create(o.width, o.height);
  ASSERT_TRUE(previewer.ok()) << to_string(previewer.error());
  auto first = (*previewer)->render(s.view(), path, o);
  ASSERT_TRUE(first.ok()) << to_string(first.error());
  const std::vector<Rgb8> first_pixels(first->row(0), first->row(0) + std::size_t(first->width) * first->height);
  const auto dir = test::scratch_dir("map-preview-again");
  ASSERT_TRUE((*previewer)->write((dir / "p.png").string(), s.view(), path, o).ok());

  test::AllocationCounter count;
  auto again = (*previewer)->render(s.view(), path, o);
  const uint64_t bytes = count.thread_bytes(), blocks = count.thread_allocations();
  ASSERT_TRUE(again.ok());
  EXPECT_LT(bytes, 20u * 1024 * blocks) << "drawing again allocated " << bytes << " bytes in " << blocks << " blocks";
  EXPECT_LT(blocks, 24u) << "more than the legend's strings";
  ASSERT_EQ(again->width, first->width);
  ASSERT_EQ(again->height, first->height);
  EXPECT_TRUE(std::equal(first_pixels.begin(), first_pixels.end(), again->row(0))) << "the same map drawn differently";
  auto fresh = render_map_preview(s.view(), path, o);
  ASSERT_TRUE(fresh.ok());
  ASSERT_EQ(fresh->width(), first->width);
  ASSERT_EQ(fresh->height(), first->height);
  EXPECT_TRUE(std::equal(first_pixels.begin(), first_pixels.end(), fresh->view().row(0)));

  // The PNG written is the picture.
  Image<Rgb8> png;
  ASSERT_TRUE(read_color_image((dir / "p.png").string(), png).ok());
  ASSERT_EQ(png.width(), first->width);
  ASSERT_EQ(png.height(), first->height);
  EXPECT_TRUE(std::equal(first_pixels.begin(), first_pixels.end(), png.view().row(0)));
}

// The path kept in memory while mapping is the one read_preview_path reads from the same poses in
// a file: bounded, evenly spaced, to the end of the run.
TEST(MapPreview, ThePathKeptWhileMappingIsTheFilesPath) {
  const auto dir = test::scratch_dir("map-preview-live-path");
  const auto file = dir / "trajectory.txt";
  PreviewPath live(1000);
  {
    std::ofstream f(file);
    for (int i = 0; i < 10000; ++i) {
      f << i * 0.033 << " " << i * 0.001 << " 0 0 0 0 0 1\n";
      live.add(SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(i * 0.001, 0, 0)));
    }
  }
  auto read = read_preview_path(file.string(), 1000);
  ASSERT_TRUE(read.ok());
  ASSERT_EQ(live.poses().size(), read->size());
  for (std::size_t i = 0; i < read->size(); ++i)
    EXPECT_NEAR(live.poses()[i].translation().x(), (*read)[i].translation().x(), 1e-9) << i;
  EXPECT_LE(live.poses().size(), 1000u);
  EXPECT_GT(live.poses().back().translation().x(), 9.0);
}

// A resumed run adds its trajectory so far (the file cut back to the checkpoint) and goes on adding
// poses as it maps: its path is the uninterrupted run's, however many times the file's part was
// thinned. An odd capacity is rounded up, so thinning keeps the path evenly spaced; a path that
// was never reserved keeps nothing.
TEST(MapPreview, AResumedRunsPathIsTheUninterruptedOnes) {
  const auto dir = test::scratch_dir("map-preview-resumed-path");
  const auto pose = [](int i) { return SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(i * 0.001, 0, 0)); };
  constexpr int kFrames = 5000, kCut = 3777;
  PreviewPath whole(100), resumed(100);
  {
    std::ofstream f(dir / "trajectory.txt");
    f << "# timestamp tx ty tz qx qy qz qw\n";
    for (int i = 0; i < kCut; ++i) f << i * 0.033 << " " << i * 0.001 << " 0 0 0 0 0 1\n";
  }
  for (int i = 0; i < kFrames; ++i) whole.add(pose(i));
  ASSERT_TRUE(resumed.add_file((dir / "trajectory.txt").string()).ok());
  for (int i = kCut; i < kFrames; ++i) resumed.add(pose(i));
  ASSERT_EQ(resumed.poses().size(), whole.poses().size());
  for (std::size_t i = 0; i < whole.poses().size(); ++i)
    EXPECT_NEAR(resumed.poses()[i].translation().x(), whole.poses()[i].translation().x(), 1e-9) << i;
  EXPECT_FALSE(resumed.add_file((dir / "none.txt").string()).ok());

  PreviewPath odd(3);
  for (int i = 0; i < 40; ++i) odd.add(pose(i));
  ASSERT_GE(odd.poses().size(), 2u);
  EXPECT_LE(odd.poses().size(), 4u);
  const double step = odd.poses()[1].translation().x() - odd.poses()[0].translation().x();
  for (std::size_t i = 1; i < odd.poses().size(); ++i)
    EXPECT_NEAR(odd.poses()[i].translation().x() - odd.poses()[i - 1].translation().x(), step, 1e-9) << i;
  EXPECT_EQ(PreviewPath::bytes_for(3), 4 * sizeof(SE3));

  PreviewPath none;
  none.add(pose(1));
  EXPECT_TRUE(none.poses().empty());
}

TEST(MapPreview, ErrorsNameTheFault) {
  const Scene s = room();
  PreviewOptions o;
  o.width = 32;
  auto bad = render_map_preview(s.view(), {}, o);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("32x480"), std::string::npos) << bad.error().message;
  SurfelCloudView empty;
  auto none = render_map_preview(empty, {}, PreviewOptions{});
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.error().message.find("no surfels"), std::string::npos);
  const auto dir = test::scratch_dir("map-preview-errors");
  const Status w = write_map_preview((dir / "no-such-folder" / "p.png").string(), s.view(), {}, PreviewOptions{});
  ASSERT_FALSE(w.ok());
  EXPECT_NE(w.error().message.find("p.png"), std::string::npos) << w.error().message;
}

}  // namespace
}  // namespace ef::pipeline
