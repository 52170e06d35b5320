// Pictures of the map (issue 33): `run` ends with preview.png and names it; `edgefusion view` draws
// a run folder, its map.ply or its checkpoint the same way; bad options are named.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "app/cli_test_util.h"
#include "core/classes.h"
#include "core/image.h"
#include "io/image_codec.h"
#include "test_support.h"

namespace ef::app {
namespace {

namespace fs = std::filesystem;

TEST(CliView, RunWritesAPreviewAndViewDrawsEveryFormOfAMap) {
  const auto dir = test::scratch_dir("cli-view");
  const std::string out = (dir / "run").string();
  auto r = cli({"run", "--source", "synthetic:?frames=30&size=160x120", "--resolution", "160x120", "--out", out,
                "--quiet"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("preview: " + (fs::path(out) / "preview.png").string()), std::string::npos) << r.out;
  Image<Rgb8> picture;
  ASSERT_TRUE(read_color_image((fs::path(out) / "preview.png").string(), picture).ok());
  EXPECT_EQ(picture.width(), 2 * 640);
  EXPECT_GT(picture.height(), 480);

  // view: the folder (its map.ply and trajectory), the PLY itself, the checkpoint; top and posed.
  int n = 0;
  for (const std::vector<std::string>& a :
       {std::vector<std::string>{out}, {(fs::path(out) / "map.ply").string(), "--top"},
        {(fs::path(out) / "checkpoint.efs").string(), "--size", "320x240"},
        {out, "--pose", "0 -1 -1 0 0 0 1", "--size", "200x100"}}) {
    std::vector<std::string> args = {"view"};
    args.insert(args.end(), a.begin(), a.end());
    const std::string png = (dir / ("view-" + std::to_string(++n) + ".png")).string();
    args.insert(args.end(), {"--out", png});
    const auto v = cli(args);
    ASSERT_EQ(v.code, 0) << a[0] << ": " << v.err;
    EXPECT_NE(v.out.find("view: " + png), std::string::npos) << v.out;
    EXPECT_NE(v.out.find("30 poses of the path"), std::string::npos) << v.out;
    Image<Rgb8> img;
    ASSERT_TRUE(read_color_image(png, img).ok()) << png;
  }
  Image<Rgb8> small;
  ASSERT_TRUE(read_color_image((dir / "view-3.png").string(), small).ok());
  EXPECT_EQ(small.width(), 640);

  // report.html beside it, naming the run and holding the preview (tests/scripts/report_html.cmake
  // renders it in Chromium).
  EXPECT_NE(r.out.find("report: " + (fs::path(out) / "report.html").string()), std::string::npos) << r.out;
  const std::string page = read_file(fs::path(out) / "report.html");
  EXPECT_EQ(page.rfind("<!DOCTYPE html>", 0), 0u);
  EXPECT_NE(page.find("synthetic:?frames=30&amp;size=160x120"), std::string::npos) << "the source, HTML-escaped";
  EXPECT_NE(page.find("<td>state</td><td>finished</td>"), std::string::npos);
  EXPECT_NE(page.find("data:image/png;base64,iVBORw0KGgo"), std::string::npos) << "the PNG signature, base64";
  EXPECT_NE(page.find("</html>"), std::string::npos);
  // The synthetic room has reference poses: the ATE against them, and their path drawn dashed.
  EXPECT_NE(page.find("<td>ATE against the source&#39;s reference poses</td><td>"), std::string::npos);
  EXPECT_NE(page.find(" over 30 poses"), std::string::npos);
  EXPECT_NE(page.find("stroke-dasharray"), std::string::npos);

  // --no-preview alone: the report still has the classes, and says it has no picture.
  r = cli({"run", "--source", "synthetic:?frames=10&size=160x120", "--resolution", "160x120", "--no-preview", "--out",
           (dir / "nopicture").string(), "--quiet"});
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string bare = read_file(dir / "nopicture" / "report.html");
  EXPECT_NE(bare.find("(no preview.png: the run wrote none)"), std::string::npos);
  EXPECT_NE(bare.find("<span class=\"sw\""), std::string::npos) << "the classes' table";
  EXPECT_EQ(bare.find("data:image/png"), std::string::npos);

  // --no-preview --no-report: neither written, neither named.
  r = cli({"run", "--source", "synthetic:?frames=10&size=160x120", "--resolution", "160x120", "--no-labels",
           "--no-preview", "--no-report", "--out", (dir / "plain").string(), "--quiet"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_FALSE(fs::exists(dir / "plain" / "preview.png"));
  EXPECT_FALSE(fs::exists(dir / "plain" / "report.html"));
  EXPECT_EQ(r.out.find("preview:"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("report:"), std::string::npos) << r.out;
}

// --labels-out DIR: the class ids for `eval labels`, and beside them (DIR_color) the same images in
// the paper's palette, one for one.
TEST(CliView, LabelImagesComeWithPaletteImagesBesideThem) {
  const auto dir = test::scratch_dir("cli-view-labels");
  const std::string labels = (dir / "labels").string();
  auto r = cli({"run", "--source", "synthetic:?frames=20&size=160x120", "--resolution", "160x120", "--out",
                (dir / "run").string(), "--labels-out", labels + "/", "--labels-out-every", "5", "--quiet"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("labels: " + labels + "/ (4 images, every 5 frames; in the palette: " + labels + "_color)"),
            std::string::npos)
      << r.out;
  int pairs = 0;
  for (const auto& e : fs::directory_iterator(labels)) {
    Image<uint8_t> ids;
    ASSERT_TRUE(read_png_u8(e.path().string(), ids).ok()) << e.path();
    Image<Rgb8> colour;
    const fs::path twin = fs::path(labels + "_color") / e.path().filename();
    ASSERT_TRUE(read_color_image(twin.string(), colour).ok()) << twin;
    ASSERT_EQ(colour.width(), ids.width());
    ASSERT_EQ(colour.height(), ids.height());
    for (int y = 0; y < ids.height(); ++y)
      for (int x = 0; x < ids.width(); ++x)
        ASSERT_EQ(colour.view()(x, y), class_color(ids.view()(x, y))) << twin << " at " << x << "," << y;
    ++pairs;
  }
  EXPECT_EQ(pairs, 4);
}

TEST(CliView, BadOptionsAreNamed) {
  const auto dir = test::scratch_dir("cli-view-bad");
  struct Case {
    std::vector<std::string> args;
    int code;
    const char* says;
  };
  const std::string png = (dir / "x.png").string();
  for (const Case& c : {Case{{"view", "map.ply"}, 2, "--out PNG is required"},
                        Case{{"view", "map.ply", "--out", png, "--size", "20x20"}, 2, "64x64..4096x4096"},
                        Case{{"view", "map.ply", "--out", png, "--size", "big"}, 2, "'big'"},
                        Case{{"view", "map.ply", "--out", png, "--top", "--pose", "0 0 0 0 0 0 1"}, 2, "give one"},
                        Case{{"view", "map.ply", "--out", png, "--pose", "1 2 3"}, 2, "7 numbers"},
                        Case{{"view", "map.ply", "--out", png, "--pose", "0 0 0 0 0 0 0"}, 2, "quaternion is zero"},
                        // Found reviewing fuzz_args (issue 34): a norm that overflows gave a NaN rotation.
                        Case{{"view", "map.ply", "--out", png, "--pose", "0 0 0 1 0 0 1e200"}, 2, "too large to normalise"},
                        Case{{"view", (dir / "missing.ply").string(), "--out", png}, 1, "missing.ply"},
                        Case{{"view", (dir / "notes.txt").string(), "--out", png}, 1, "not a map"}}) {
    const auto r = cli(c.args);
    std::string line;
    for (const auto& a : c.args) line += " " + a;
    EXPECT_EQ(r.code, c.code) << line << ": " << r.err;
    EXPECT_NE(r.err.find(c.says), std::string::npos) << line << ": " << r.err;
  }
  EXPECT_FALSE(fs::exists(png));
}

}  // namespace
}  // namespace ef::app
