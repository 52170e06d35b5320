// Writes a known surfel PLY for tests/scripts/check_ply_open3d.py, which recomputes the same values
// from the formulas below (kept in step by hand) and checks what Open3D reads.
//   usage: ply_fixture OUT.ply
#include <cstdio>
#include <filesystem>
#include <vector>

#include "io/ply_writer.h"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: ply_fixture OUT.ply\n");
    return 2;
  }
  const std::filesystem::path out = argv[1];
  std::error_code ec;
  if (out.has_parent_path()) std::filesystem::create_directories(out.parent_path(), ec);

  constexpr int kN = 7;
  std::vector<float> x(kN), y(kN), z(kN), nx(kN), ny(kN), nz(kN), radius(kN), conf(kN), prob(kN);
  std::vector<uint8_t> r(kN), g(kN), b(kN), cls(kN);
  for (int i = 0; i < kN; ++i) {
    x[i] = 0.25f * i;           // metres
    y[i] = 1.0f - 0.5f * i;
    z[i] = 2.0f + 0.125f * i;
    nx[i] = i % 3 == 0 ? 1.0f : 0.0f;  // unit axes cycling x, y, z
    ny[i] = i % 3 == 1 ? 1.0f : 0.0f;
    nz[i] = i % 3 == 2 ? 1.0f : 0.0f;
    r[i] = static_cast<uint8_t>(30 * i);
    g[i] = static_cast<uint8_t>(255 - 20 * i);
    b[i] = static_cast<uint8_t>(7 * i);
    radius[i] = 0.5f * (i + 1) / 64.0f;  // exact in binary: 1/128 steps
    conf[i] = static_cast<float>(i);
    cls[i] = static_cast<uint8_t>(i % 14);
    prob[i] = 0.125f * i;
  }
  ef::SurfelCloudView v;
  v.count = kN;
  v.x = x.data();
  v.y = y.data();
  v.z = z.data();
  v.nx = nx.data();
  v.ny = ny.data();
  v.nz = nz.data();
  v.red = r.data();
  v.green = g.data();
  v.blue = b.data();
  v.radius = radius.data();
  v.confidence = conf.data();
  v.class_id = cls.data();
  v.class_prob = prob.data();
  const ef::Status s = ef::write_surfel_ply(out.string(), v, "ply_fixture");
  if (!s.ok()) {
    std::fprintf(stderr, "ply_fixture: %s\n", ef::to_string(s.error()).c_str());
    return 1;
  }
  std::printf("ply_fixture: wrote %d surfels to %s\n", kN, out.string().c_str());
  return 0;
}
