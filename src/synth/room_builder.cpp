#include "synth/room_builder.h"

#include <algorithm>
#include <cmath>

#include "synth/det_math.h"
#include "synth/rng.h"
#include "synth/trajectory.h"

namespace ef::synth {

namespace {

using Vec2 = Eigen::Vector2f;
using Vec3 = Eigen::Vector3f;
constexpr float kPi = 3.14159265f;

// v rotated by `yaw` radians in the floor plane (det_math: the same bits on every machine).
Vec2 rotate(float yaw, const Vec2& v) {
  float s, c;
  det_sincosf(yaw, s, c);
  return Vec2(c * v.x() - s * v.y(), s * v.x() + c * v.y());
}

// Where a piece of furniture stands: its footprint centre on the floor (world metres) and its yaw
// (radians). Its own frame: x along its width, y towards its front, z up from the floor.
struct Placement {
  Vec2 origin{0, 0};
  float yaw = 0;
};

// Axis-aligned world box of something placed, to keep things from overlapping.
struct Aabb {
  Vec3 lo, hi;
  bool overlaps(const Aabb& o, float gap) const {
    for (int i = 0; i < 3; ++i)
      if (lo[i] >= o.hi[i] + gap || o.lo[i] >= hi[i] + gap) return false;
    return true;
  }
};

enum class RoomKind { kLiving, kBedroom, kOffice, kKitchen, kLibrary };

// The forms of the middle group (RoomLayout::kIsland), in Builder::island_variant's order. Metres:
// the main piece's width is drawn in [width_lo, width_hi] and may shrink to min_width; the
// footprint's half sizes are width / 2 + extra_half_x along it and half_y across it; `top` is the
// highest point of the group with what stands on it (clutter is up to 0.24 m tall).
struct IslandVariant {
  float width_lo, width_hi, min_width, extra_half_x, half_y, top;
};
constexpr IslandVariant kIslandVariants[5] = {
    {0.9f, 1.3f, 0.8f, 0.5f, 0.42f, 0.99f},  // dining table, a chair at each end (backs 0.97 m)
    {1.6f, 2.0f, 1.4f, 0.0f, 0.45f, 0.85f},  // free-standing sofa
    {1.0f, 1.5f, 0.8f, 0.0f, 0.8f, 1.18f},   // counter (worktop 0.94 m) and chairs at its front
    {0.8f, 1.2f, 0.8f, 0.0f, 0.33f, 1.3f},   // two bookshelves back to back, up to 1.3 m
    {0.7f, 1.0f, 0.6f, 0.0f, 0.28f, 0.69f},  // low table (0.45 m) with things on it
};

class Builder {
 public:
  Builder(Scene& scene, uint32_t seed) : s_(scene), rng_(seed, 0x2545f4914f6cdd1dULL), seed_(seed) {}

  Pcg32& rng() { return rng_; }
  float W() const { return s_.size.x(); }
  float D() const { return s_.size.y(); }
  float H() const { return s_.size.z(); }
  float wall_length(int wall) const { return wall % 2 == 0 ? W() : D(); }

  // --- materials ------------------------------------------------------------------------------
  uint32_t next_seed() { return hash32(seed_, counter_++); }
  Material mat(TextureKind kind, Vec3 base, Vec3 accent, float scale) {
    Material m;
    m.texture = kind;
    m.base = base;
    m.accent = accent;
    m.scale = scale;
    m.seed = next_seed();
    return m;
  }
  // Random draws are always separate statements: the order in which the arguments of one call
  // are evaluated is unspecified, and GCC picks different orders on x86-64 (last argument first)
  // and ARM64 (first argument first). The draws are made in the order the x86-64 builds always
  // made them, so the rooms generated on x86-64 so far stay what they were.
  Vec3 vary(const Vec3& c, float amount) {
    const float fb = rng_.uniform(1 - amount, 1 + amount);
    const float fg = rng_.uniform(1 - amount, 1 + amount);
    const float fr = rng_.uniform(1 - amount, 1 + amount);
    return Vec3(c.x() * fr, c.y() * fg, c.z() * fb).cwiseMin(1.0f);
  }
  Material wood() {
    static const Vec3 kWoods[4] = {{0.55f, 0.36f, 0.2f}, {0.75f, 0.6f, 0.42f}, {0.35f, 0.2f, 0.12f}, {0.85f, 0.75f, 0.6f}};
    const Vec3 b = vary(kWoods[rng_.below(4)], 0.1f);
    return mat(TextureKind::kWood, b, b * 0.6f, rng_.uniform(0.03f, 0.08f));
  }
  Material painted() {
    static const Vec3 kPaints[5] = {{0.9f, 0.9f, 0.88f}, {0.3f, 0.35f, 0.4f}, {0.7f, 0.2f, 0.2f}, {0.2f, 0.4f, 0.55f}, {0.85f, 0.8f, 0.6f}};
    return mat(TextureKind::kPlain, vary(kPaints[rng_.below(5)], 0.08f), Vec3::Zero(), 0.3f);
  }
  Material fabric() {
    static const Vec3 kCloth[6] = {{0.6f, 0.15f, 0.15f}, {0.2f, 0.3f, 0.6f}, {0.5f, 0.55f, 0.3f},
                                   {0.45f, 0.45f, 0.48f}, {0.75f, 0.6f, 0.4f}, {0.3f, 0.5f, 0.5f}};
    const Vec3 b = vary(kCloth[rng_.below(6)], 0.1f);
    return mat(TextureKind::kFabric, b, b * 0.55f, rng_.uniform(0.05f, 0.2f));
  }
  Material stripes() {
    const Vec3 b = fabric().base;
    const float scale = rng_.uniform(0.08f, 0.2f);
    const Vec3 accent = vary(Vec3(0.9f, 0.88f, 0.8f), 0.1f);
    return mat(TextureKind::kStripes, b, accent, scale);
  }
  Material metal() { return mat(TextureKind::kPlain, vary(Vec3(0.3f, 0.3f, 0.32f), 0.2f), Vec3::Zero(), 0.1f); }
  Material bright() {
    static const Vec3 kBright[5] = {{0.9f, 0.3f, 0.1f}, {0.1f, 0.6f, 0.8f}, {0.9f, 0.8f, 0.1f}, {0.3f, 0.7f, 0.3f}, {0.85f, 0.85f, 0.85f}};
    return mat(TextureKind::kPlain, kBright[rng_.below(5)], Vec3::Zero(), 0.05f);
  }

  // --- the room shell -------------------------------------------------------------------------
  void shell(Vec3 size) {
    s_.size = size;
    const Vec3 wall_col = vary(Vec3(0.82f, 0.8f, 0.74f), 0.12f);
    const bool paper = rng_.chance(0.4f);
    for (int f = kWallYMin; f <= kWallXMin; ++f) {
      if (paper && f == kWallYMax) {
        const float scale = rng_.uniform(0.15f, 0.3f);
        const Vec3 accent = vary(Vec3(0.55f, 0.45f, 0.4f), 0.2f);
        s_.face_material[f] = mat(TextureKind::kWallpaper, wall_col, accent, scale);
      } else {
        s_.face_material[f] = mat(TextureKind::kPlaster, wall_col, Vec3::Zero(), rng_.uniform(0.15f, 0.4f));
      }
    }
    s_.face_material[kCeilingFace] = mat(TextureKind::kPlaster, Vec3(0.9f, 0.9f, 0.9f), Vec3::Zero(), 0.5f);
    if (rng_.chance(0.6f)) {
      const Material w = wood();
      s_.face_material[kFloorFace] = mat(TextureKind::kPlanks, w.base, w.accent, rng_.uniform(0.12f, 0.22f));
    } else {
      const float scale = rng_.uniform(0.3f, 0.6f);
      const Vec3 base = vary(Vec3(0.7f, 0.68f, 0.62f), 0.2f);
      s_.face_material[kFloorFace] = mat(TextureKind::kTiles, base, Vec3(0.3f, 0.3f, 0.3f), scale);
    }
    // Two ceiling lights along the longer axis, warm to cool, and an ambient term.
    const Vec3 tint = rng_.chance(0.5f) ? Vec3(1.0f, 0.92f, 0.8f) : Vec3(0.92f, 0.95f, 1.0f);
    const float power = rng_.uniform(0.75f, 1.0f);
    for (int i = 0; i < 2; ++i) {
      Light l;
      const float f = i == 0 ? 0.3f : 0.7f;
      l.position = W() >= D() ? Vec3(W() * f, D() * 0.5f, H() - 0.25f) : Vec3(W() * 0.5f, D() * f, H() - 0.25f);
      l.color = tint * power;
      l.falloff = 3.0f;
      s_.lights.push_back(l);
    }
    s_.ambient = Vec3::Constant(rng_.uniform(0.22f, 0.32f));
  }

  // --- placing ---------------------------------------------------------------------------------
  // The frame of something standing against wall `wall` (0: y = 0, 1: x = W, 2: y = D, 3: x = 0)
  // at coordinate `along` (world x for walls 0 and 2, world y for 1 and 3), its centre `off`
  // metres from the wall, facing into the room.
  Placement at_wall(int wall, float along, float off) const {
    switch (wall) {
      case 0: return {Vec2(along, off), 0.0f};
      case 1: return {Vec2(W() - off, along), kPi / 2};
      case 2: return {Vec2(along, D() - off), kPi};
      default: return {Vec2(off, along), -kPi / 2};
    }
  }

  // World AABB of a local box (centre c, half extents h) of a placement.
  static Aabb bounds(const Placement& pl, const Vec3& c, const Vec3& h) {
    float sn, cs;
    det_sincosf(pl.yaw, sn, cs);
    cs = std::fabs(cs);
    sn = std::fabs(sn);
    const Vec2 w = pl.origin + rotate(pl.yaw, Vec2(c.x(), c.y()));
    const Vec3 e(cs * h.x() + sn * h.y(), sn * h.x() + cs * h.y(), h.z());
    return Aabb{Vec3(w.x(), w.y(), c.z()) - e, Vec3(w.x(), w.y(), c.z()) + e};
  }

  // Finds a free spot on `wall` for a footprint of `width` x `depth` (metres) and height range
  // [z0, z1], `gap` metres off the wall; false when none after a few tries. Reserves it.
  bool find_wall_spot(int wall, float width, float depth, float z0, float z1, float gap, Placement& out) {
    const float len = wall_length(wall);
    if (width + 0.2f > len) return false;
    for (int attempt = 0; attempt < 40; ++attempt) {
      const float along = rng_.uniform(0.1f + width / 2, len - 0.1f - width / 2);
      const Placement pl = at_wall(wall, along, gap + depth / 2);
      const Aabb box = bounds(pl, Vec3(0, 0, (z0 + z1) / 2), Vec3(width / 2, depth / 2, (z1 - z0) / 2));
      bool free = true;
      for (const Aabb& o : used_) free = free && !box.overlaps(o, 0.08f);
      if (!free) continue;
      used_.push_back(box);
      out = pl;
      return true;
    }
    return false;
  }
  // Tries the preferred wall first, then the others in order.
  bool find_any_wall_spot(int preferred, float width, float depth, float z0, float z1, float gap, Placement& out) {
    for (int k = 0; k < 4; ++k)
      if (find_wall_spot((preferred + k) % 4, width, depth, z0, z1, gap, out)) return true;
    return false;
  }
  void reserve(const Placement& pl, const Vec3& c, const Vec3& h) { used_.push_back(bounds(pl, c, h)); }
  bool is_free(const Placement& pl, const Vec3& c, const Vec3& h) const {
    const Aabb box = bounds(pl, c, h);
    if (box.lo.x() < 0.02f || box.lo.y() < 0.02f || box.hi.x() > W() - 0.02f || box.hi.y() > D() - 0.02f) return false;
    for (const Aabb& o : used_)
      if (box.overlaps(o, 0.05f)) return false;
    return true;
  }

  // Adds a part: a primitive centred at `c` in the placement's frame (metres), half extents `h`.
  void part(const Placement& pl, Vec3 c, Vec3 h, uint8_t label, const Material& m, Shape shape = Shape::kBox,
            float extra_yaw = 0) {
    Primitive p;
    p.shape = shape;
    const Vec2 w = pl.origin + rotate(pl.yaw, Vec2(c.x(), c.y()));
    p.center = Vec3(w.x(), w.y(), c.z());
    p.half = h;
    p.yaw = pl.yaw + extra_yaw;
    p.label = label;
    p.material = m;
    s_.add(p);
  }

  // --- furniture, all in the placement's frame (front = +y) ----------------------------------
  void bed(const Placement& pl, float w, float l) {
    const Material frame = wood(), sheet = fabric(), cover = rng_.chance(0.5f) ? stripes() : fabric();
    const Material pillow = mat(TextureKind::kFabric, Vec3(0.9f, 0.9f, 0.88f), Vec3(0.7f, 0.7f, 0.7f), 0.1f);
    part(pl, Vec3(0, 0, 0.15f), Vec3(w / 2, l / 2, 0.15f), kBed, frame);
    part(pl, Vec3(0, 0.02f, 0.4f), Vec3(w / 2 - 0.03f, l / 2 - 0.05f, 0.1f), kBed, sheet);
    part(pl, Vec3(0, l * 0.15f, 0.52f), Vec3(w / 2 - 0.01f, l * 0.33f, 0.025f), kBed, cover);
    part(pl, Vec3(0, -l / 2 + 0.03f, 0.55f), Vec3(w / 2, 0.03f, 0.55f), kBed, frame);
    const int pillows = w > 1.2f ? 2 : 1;
    for (int i = 0; i < pillows; ++i) {
      const float x = pillows == 1 ? 0.0f : (i == 0 ? -w / 4 : w / 4);
      part(pl, Vec3(x, -l / 2 + 0.28f, 0.56f), Vec3(std::min(0.3f, w / 4 - 0.03f), 0.18f, 0.06f), kBed, pillow);
    }
  }
  void chair(const Placement& pl) {
    const Material m = rng_.chance(0.5f) ? wood() : painted();
    const Material seat = rng_.chance(0.5f) ? fabric() : m;
    part(pl, Vec3(0, 0, 0.45f), Vec3(0.22f, 0.22f, 0.025f), kChair, seat);
    part(pl, Vec3(0, -0.2f, 0.72f), Vec3(0.22f, 0.02f, 0.25f), kChair, m);
    for (int i = 0; i < 4; ++i) {
      const float x = i % 2 ? 0.19f : -0.19f, y = i / 2 ? 0.19f : -0.19f;
      part(pl, Vec3(x, y, 0.21f), Vec3(0.02f, 0.02f, 0.21f), kChair, m, Shape::kCylinder);
    }
  }
  void armchair(const Placement& pl) {
    const Material m = fabric();
    part(pl, Vec3(0, 0, 0.22f), Vec3(0.4f, 0.4f, 0.22f), kChair, m);
    part(pl, Vec3(0, -0.32f, 0.6f), Vec3(0.4f, 0.08f, 0.2f), kChair, m);
    part(pl, Vec3(-0.34f, 0, 0.52f), Vec3(0.07f, 0.4f, 0.1f), kChair, m);
    part(pl, Vec3(0.34f, 0, 0.52f), Vec3(0.07f, 0.4f, 0.1f), kChair, m);
  }
  void table(const Placement& pl, float w, float d, float h) {
    const Material m = wood();
    part(pl, Vec3(0, 0, h - 0.02f), Vec3(w / 2, d / 2, 0.02f), kTable, m);
    for (int i = 0; i < 4; ++i) {
      const float x = (i % 2 ? 1 : -1) * (w / 2 - 0.06f), y = (i / 2 ? 1 : -1) * (d / 2 - 0.06f);
      part(pl, Vec3(x, y, (h - 0.04f) / 2), Vec3(0.03f, 0.03f, (h - 0.04f) / 2), kTable, m);
    }
  }
  void sofa(const Placement& pl, float w) {
    const Material m = fabric();
    Material cushion = m;
    cushion.base = vary(m.base, 0.1f);
    cushion.seed = next_seed();
    const float d = 0.9f;
    part(pl, Vec3(0, 0.02f, 0.21f), Vec3(w / 2 - 0.18f, d / 2 - 0.02f, 0.21f), kSofa, m);
    part(pl, Vec3(0, -d / 2 + 0.1f, 0.5f), Vec3(w / 2, 0.1f, 0.35f), kSofa, m);
    part(pl, Vec3(-w / 2 + 0.1f, 0.02f, 0.31f), Vec3(0.1f, d / 2 - 0.02f, 0.31f), kSofa, m);
    part(pl, Vec3(w / 2 - 0.1f, 0.02f, 0.31f), Vec3(0.1f, d / 2 - 0.02f, 0.31f), kSofa, m);
    const int n = w > 2.0f ? 3 : 2;
    const float cw = (w - 0.4f) / static_cast<float>(n);
    for (int i = 0; i < n; ++i) {
      const float x = -w / 2 + 0.2f + cw * (static_cast<float>(i) + 0.5f);
      part(pl, Vec3(x, 0.1f, 0.48f), Vec3(cw / 2 - 0.01f, 0.3f, 0.06f), kSofa, cushion);
    }
    part(pl, Vec3(-w / 2 + 0.45f, -d / 2 + 0.28f, 0.68f), Vec3(0.2f, 0.06f, 0.17f), kSofa, stripes(), Shape::kBox, 0.2f);
  }
  // A cabinet (doors, handles) of w x d x h; returns its height (for things put on top).
  void cabinet(const Placement& pl, float w, float d, float h) {
    const Material body = rng_.chance(0.5f) ? wood() : painted();
    const Material handle = metal();
    part(pl, Vec3(0, 0, h / 2), Vec3(w / 2, d / 2, h / 2), kFurniture, body);
    const int doors = std::max(1, static_cast<int>(w / 0.5f));
    const float dw = w / static_cast<float>(doors);
    Material door = body;
    door.base = body.base * 0.9f;
    for (int i = 0; i < doors; ++i) {
      const float x = -w / 2 + dw * (static_cast<float>(i) + 0.5f);
      part(pl, Vec3(x, d / 2 + 0.008f, h / 2 + 0.02f), Vec3(dw / 2 - 0.015f, 0.008f, h / 2 - 0.06f), kFurniture, door);
      part(pl, Vec3(x + dw / 2 - 0.07f, d / 2 + 0.025f, h * 0.6f), Vec3(0.01f, 0.01f, 0.06f), kFurniture, handle);
    }
  }
  void bookshelf(const Placement& pl, float w, float h) {
    const float d = 0.32f;
    const Material m = wood();
    part(pl, Vec3(0, -d / 2 + 0.01f, h / 2), Vec3(w / 2, 0.01f, h / 2), kFurniture, m);
    part(pl, Vec3(-w / 2 + 0.01f, 0, h / 2), Vec3(0.01f, d / 2, h / 2), kFurniture, m);
    part(pl, Vec3(w / 2 - 0.01f, 0, h / 2), Vec3(0.01f, d / 2, h / 2), kFurniture, m);
    const int levels = std::max(3, static_cast<int>(h / 0.38f));
    const float step = (h - 0.04f) / static_cast<float>(levels);
    for (int i = 0; i <= levels; ++i) {
      const float z = 0.02f + step * static_cast<float>(i);
      part(pl, Vec3(0, 0, z), Vec3(w / 2 - 0.02f, d / 2 - 0.005f, 0.015f), kFurniture, m);
      if (i == levels) break;
      // Blocks of books with varied heights, depths and gaps; sometimes an object instead.
      float x = -w / 2 + 0.03f + rng_.uniform(0.0f, 0.1f);
      while (x < w / 2 - 0.12f) {
        const float bw = std::min(rng_.uniform(0.12f, 0.4f), w / 2 - 0.03f - x);
        if (bw < 0.05f) break;
        const float bh = std::min(rng_.uniform(0.17f, 0.3f), step - 0.05f);
        const float bd = rng_.uniform(0.15f, 0.24f);
        if (rng_.chance(0.12f)) {
          part(pl, Vec3(x + 0.06f, 0.0f, z + 0.015f + 0.06f), Vec3(0.05f, 0.05f, 0.06f), kObjects, bright(), Shape::kCylinder);
        } else {
          Material spines = mat(TextureKind::kBookSpines, Vec3::Zero(), Vec3::Zero(), rng_.uniform(0.025f, 0.045f));
          part(pl, Vec3(x + bw / 2, d / 2 - 0.02f - bd / 2, z + 0.015f + bh / 2), Vec3(bw / 2, bd / 2, bh / 2), kBooks, spines);
        }
        x += bw + rng_.uniform(0.01f, 0.12f);
      }
    }
  }
  void wardrobe(const Placement& pl, float w) { cabinet(pl, w, 0.6f, std::min(2.1f, H() - 0.2f)); }
  void tv(const Placement& pl, float z_base, float w) {
    const float h = w * 0.58f;
    Material screen = mat(TextureKind::kScreen, Vec3(0.05f, 0.06f, 0.08f), Vec3(0.02f, 0.02f, 0.02f), 0.1f);
    screen.emission = 0.5f;
    part(pl, Vec3(0, 0, z_base + 0.02f), Vec3(0.15f, 0.08f, 0.02f), kTv, metal());
    part(pl, Vec3(0, 0, z_base + 0.04f + h / 2 + 0.04f), Vec3(w / 2, 0.03f, h / 2), kTv, screen);
  }
  // Small objects scattered on a top surface at height z (local rectangle centred at c, half size hs).
  void clutter(const Placement& pl, Vec2 c, Vec2 hs, float z, int count) {
    for (int i = 0; i < count; ++i) {
      const float x = c.x() + rng_.uniform(-hs.x(), hs.x());
      const float y = c.y() + rng_.uniform(-hs.y(), hs.y());
      switch (rng_.below(5)) {
        case 0:  // cup
          part(pl, Vec3(x, y, z + 0.05f), Vec3(0.04f, 0.04f, 0.05f), kObjects, bright(), Shape::kCylinder);
          break;
        case 1: {  // box
          const float yaw = rng_.uniform(-1, 1);
          const Material m = painted();
          part(pl, Vec3(x, y, z + 0.05f), Vec3(0.1f, 0.07f, 0.05f), kObjects, m, Shape::kBox, yaw);
          break;
        }
        case 2:  // ball / fruit
          part(pl, Vec3(x, y, z + 0.06f), Vec3::Constant(0.06f), kObjects, bright(), Shape::kSphere);
          break;
        case 3:  // vase
          part(pl, Vec3(x, y, z + 0.12f), Vec3(0.06f, 0.06f, 0.12f), kObjects, stripes(), Shape::kCylinder);
          break;
        default:  // bowl
          part(pl, Vec3(x, y, z + 0.03f), Vec3(0.1f, 0.1f, 0.03f), kObjects, bright(), Shape::kCylinder);
          break;
      }
    }
  }
  void lamp(const Placement& pl, float z_base, float h) {
    part(pl, Vec3(0, 0, z_base + 0.015f), Vec3(0.12f, 0.12f, 0.015f), kObjects, metal(), Shape::kCylinder);
    part(pl, Vec3(0, 0, z_base + h / 2), Vec3(0.015f, 0.015f, h / 2), kObjects, metal(), Shape::kCylinder);
    Material shade = fabric();
    shade.base = vary(Vec3(0.95f, 0.9f, 0.75f), 0.05f);
    shade.emission = 0.3f;
    part(pl, Vec3(0, 0, z_base + h + 0.08f), Vec3(0.17f, 0.17f, 0.12f), kObjects, shade, Shape::kCylinder);
  }
  void plant(const Placement& pl) {
    part(pl, Vec3(0, 0, 0.17f), Vec3(0.16f, 0.16f, 0.17f), kObjects, painted(), Shape::kCylinder);
    const Material leaves = mat(TextureKind::kFabric, vary(Vec3(0.15f, 0.45f, 0.15f), 0.2f), Vec3(0.05f, 0.2f, 0.05f), 0.05f);
    part(pl, Vec3(0, 0, 0.62f), Vec3::Constant(0.3f), kObjects, leaves, Shape::kSphere);
  }
  void rug(const Placement& pl, float w, float d) {
    // Rugs count as floor (as in NYUv2); a thin box so the floor has more texture.
    part(pl, Vec3(0, 0, 0.005f), Vec3(w / 2, d / 2, 0.005f), kFloor, stripes());
  }

  // --- furniture in the middle of the room (RoomLayout::kIsland) --------------------------------
  // One group of furniture near the room's middle that keeps `clearance` metres from every point of
  // `lap` (the camera's path: trajectory_lap) and clear of what the recipe placed. With `pass_over`
  // (the hand-held loop) the camera may pass over the group, at the lap's base height less its swing
  // (kHandheldHeightSwing); otherwise (a robot) only the floor-plane distance counts. The hand-held
  // loop circles the group and looks across it, so it hides a different part of the far side in
  // every view. Variants, drawn from the seed (one that does not fit gives way to the next, and each
  // is tried at full and reduced width, at the centre and then up to 0.6 m off it, nearest first): a
  // dining table with a chair at each end, a sofa standing free (its back to one side of the loop),
  // a kitchen counter with chairs at its front, two bookshelves back to back; last, in any room, a
  // low table with things on it. False when none fits.
  bool island(const std::vector<Vec3>& lap, float clearance, bool pass_over) {
    const int first = static_cast<int>(rng_.below(4));
    const bool flip = rng_.chance(0.5f);  // which side of the group faces which way
    // Local x runs along the room's longer side.
    const float yaw = (W() >= D() ? 0.0f : kPi / 2) + (flip ? kPi : 0.0f);
    // Offsets from the centre (metres) on a 0.15 m grid, nearest first (ties in grid order).
    std::vector<Vec2> shifts;
    for (int iy = -4; iy <= 4; ++iy)
      for (int ix = -4; ix <= 4; ++ix) shifts.emplace_back(0.15f * static_cast<float>(ix), 0.15f * static_cast<float>(iy));
    std::stable_sort(shifts.begin(), shifts.end(), [](const Vec2& a, const Vec2& b) { return a.squaredNorm() < b.squaredNorm(); });
    for (int k = 0; k < 5; ++k) {
      const int variant = k < 4 ? (first + k) % 4 : 4;
      const IslandVariant& v = kIslandVariants[variant];
      const float drawn = rng_.uniform(v.width_lo, v.width_hi);
      for (const float scale : {1.0f, 0.85f, 0.7f}) {
        const float width = std::max(v.min_width, drawn * scale);
        const Vec2 half(width / 2 + v.extra_half_x, v.half_y);
        for (const Vec2& shift : shifts) {
          Placement pl;
          pl.yaw = yaw;
          pl.origin = Vec2(W() / 2, D() / 2) + shift;
          const Vec3 c(0, 0, 0.5f), h(half.x(), half.y(), 0.5f);
          if (!is_free(pl, c, h) || !clear_of(lap, pl, half, v.top, clearance, pass_over)) continue;
          reserve(pl, c, h);
          island_variant(variant, pl, width);
          return true;
        }
      }
    }
    return false;
  }
  // True when every point of `path` keeps `clearance` metres from the box of half sizes `half`
  // that stands on the floor under placement `pl`, up to `top` metres (the scene's own box
  // distance): with `pass_over` (hand-held) the point is taken kHandheldHeightSwing lower, the
  // lowest the camera gets; otherwise (a robot) at the box's mid-height, so only the floor-plane
  // distance counts.
  static bool clear_of(const std::vector<Vec3>& path, const Placement& pl, const Vec2& half, float top, float clearance,
                       bool pass_over) {
    Primitive box;  // a box, never added to the scene
    box.center = Vec3(pl.origin.x(), pl.origin.y(), top / 2);
    box.half = Vec3(half.x(), half.y(), top / 2);
    box.yaw = pl.yaw;
    det_sincosf(box.yaw, box.sin_yaw, box.cos_yaw);
    for (const Vec3& p : path) {
      const Vec3 q(p.x(), p.y(), pass_over ? p.z() - static_cast<float>(kHandheldHeightSwing) : top / 2);
      if (box.local_signed_distance(box.to_local(q)) < clearance) return false;
    }
    return true;
  }

  // --- wall items -----------------------------------------------------------------------------
  bool window(int wall, float w, float h) {
    Placement pl;
    const float z0 = std::min(0.9f, H() - h - 0.2f);
    if (!find_any_wall_spot(wall, w, 0.04f, z0, z0 + h, 0.0f, pl)) return false;
    Material sky = mat(TextureKind::kSky, vary(Vec3(0.35f, 0.55f, 0.9f), 0.1f), Vec3(0.95f, 0.95f, 0.93f), 1.0f);
    sky.emission = 0.85f;
    part(pl, Vec3(0, 0, z0 + h / 2), Vec3(w / 2, 0.02f, h / 2), kWindow, sky);
    return true;
  }
  bool painting(int wall, float w, float h, float z_centre) {
    Placement pl;
    if (!find_any_wall_spot(wall, w, 0.03f, z_centre - h / 2, z_centre + h / 2, 0.0f, pl)) return false;
    const Material m = mat(TextureKind::kPainting, Vec3::Zero(), wood().base * 0.6f, 1.0f);
    part(pl, Vec3(0, 0, z_centre), Vec3(w / 2, 0.015f, h / 2), kPainting, m);
    return true;
  }

  // The furniture of island variant `variant` (see island()) around `pl`, `width` metres wide.
  void island_variant(int variant, const Placement& pl, float width) {
    switch (variant) {
      case 0: {  // dining table, a chair at each end facing it, things on the table
        const float depth = rng_.uniform(0.7f, 0.84f);
        table(pl, width, depth, 0.75f);
        clutter(pl, Vec2(0, 0), Vec2(width / 2 - 0.15f, depth / 2 - 0.12f), 0.75f, 2 + static_cast<int>(rng_.below(3)));
        for (int side = -1; side <= 1; side += 2) {
          Placement c = pl;
          c.origin += rotate(pl.yaw, Vec2(static_cast<float>(side) * (width / 2 + 0.3f), 0));
          c.yaw += static_cast<float>(side) * kPi / 2 + rng_.uniform(-0.2f, 0.2f);
          chair(c);
        }
        break;
      }
      case 1:  // a sofa standing free: its back (local -y) faces one side of the loop
        sofa(pl, width);
        break;
      case 2: {  // kitchen counter with a worktop and things on it, two chairs at its front
        const float depth = 0.6f;
        Placement body = pl;
        body.origin += rotate(pl.yaw, Vec2(0, -0.2f));
        cabinet(body, width, depth, 0.9f);
        part(body, Vec3(0, 0.02f, 0.92f), Vec3(width / 2 + 0.02f, depth / 2 + 0.01f, 0.02f), kFurniture,
             mat(TextureKind::kTiles, Vec3(0.8f, 0.8f, 0.78f), Vec3(0.4f, 0.4f, 0.4f), 0.1f));
        clutter(body, Vec2(0, 0), Vec2(width / 2 - 0.15f, 0.18f), 0.94f, 2 + static_cast<int>(rng_.below(3)));
        for (int i = 0; i < 2; ++i) {
          Placement c = pl;
          c.origin += rotate(pl.yaw, Vec2((i == 0 ? -0.25f : 0.25f) * width, 0.45f));
          c.yaw += kPi + rng_.uniform(-0.3f, 0.3f);
          chair(c);
        }
        break;
      }
      case 4: {  // a low table with things on it
        const float depth = rng_.uniform(0.45f, 0.55f);
        table(pl, width, depth, 0.45f);
        clutter(pl, Vec2(0, 0), Vec2(width / 2 - 0.12f, depth / 2 - 0.1f), 0.45f, 1 + static_cast<int>(rng_.below(3)));
        break;
      }
      default: {  // two bookshelves back to back, books on both sides
        const float h = rng_.uniform(1.0f, 1.3f);
        for (int side = 0; side < 2; ++side) {
          Placement s = pl;
          s.origin += rotate(pl.yaw, Vec2(0, side == 0 ? 0.165f : -0.165f));
          s.yaw += side == 0 ? 0.0f : kPi;
          bookshelf(s, width, h);
        }
        break;
      }
    }
  }

 private:
  Scene& s_;
  Pcg32 rng_;
  uint32_t seed_;
  uint32_t counter_ = 0;
  std::vector<Aabb> used_;
};

// --- room recipes ---------------------------------------------------------------------------
// Every recipe puts furniture along the walls and keeps the middle free (the hand-held loop and
// the robot path run there); sizes and positions vary with the builder's seed.

void living_room(Builder& b) {
  Pcg32& r = b.rng();
  const float height = r.uniform(2.5f, 2.9f);  // drawn last to first (see Builder::vary)
  const float depth = r.uniform(4.2f, 5.5f);
  const float width = r.uniform(5.0f, 6.5f);
  b.shell(Vec3(width, depth, height));
  const int back = static_cast<int>(r.below(2)) * 2;  // sofa on wall 0 or 2
  Placement pl;
  const float sw = r.uniform(1.9f, 2.4f);
  if (b.find_wall_spot(back, sw, 0.9f, 0, 1.0f, 0.02f, pl)) {
    b.sofa(pl, sw);
    Placement front = pl;
    front.origin += rotate(pl.yaw, Vec2(0, 0.45f + 0.3f + 0.35f));
    if (b.is_free(front, Vec3(0, 0, 0.25f), Vec3(0.55f, 0.3f, 0.25f))) {
      b.rug(front, 2.0f, 1.4f);
      b.table(front, 1.1f, 0.6f, 0.45f);
      b.clutter(front, Vec2(0, 0), Vec2(0.4f, 0.2f), 0.45f, 3);
      b.reserve(front, Vec3(0, 0, 0.25f), Vec3(0.55f, 0.3f, 0.25f));
    }
  }
  {
    const float h = r.uniform(0.5f, 0.8f);  // drawn last to first (see Builder::vary)
    const float w = r.uniform(0.8f, 1.3f);
    b.painting(back, w, h, 1.6f);
  }
  const int opposite = (back + 2) % 4;
  if (b.find_wall_spot(opposite, 1.6f, 0.45f, 0, 1.4f, 0.02f, pl)) {
    b.cabinet(pl, 1.6f, 0.45f, 0.5f);
    b.tv(pl, 0.5f, r.uniform(0.9f, 1.2f));
    b.clutter(pl, Vec2(0.65f, 0), Vec2(0.05f, 0.1f), 0.5f, 1);
  }
  if (b.find_any_wall_spot(1, 1.0f, 0.32f, 0, 2.0f, 0.02f, pl)) b.bookshelf(pl, 1.0f, r.uniform(1.6f, 2.0f));
  if (b.find_any_wall_spot(3, 0.85f, 0.85f, 0, 1.0f, 0.1f, pl)) b.armchair(pl);
  if (b.find_any_wall_spot(1, 0.4f, 0.4f, 0, 1.9f, 0.1f, pl)) b.lamp(pl, 0, 1.55f);
  if (b.find_any_wall_spot(3, 0.6f, 0.6f, 0, 1.0f, 0.05f, pl)) b.plant(pl);
  {
    const float h = r.uniform(1.1f, 1.4f);  // drawn last to first (see Builder::vary)
    const float w = r.uniform(1.0f, 1.6f);
    b.window(3, w, h);
  }
  {
    const float h = r.uniform(1.1f, 1.4f);  // drawn last to first (see Builder::vary)
    const float w = r.uniform(0.9f, 1.3f);
    b.window(1, w, h);
  }
  b.painting(1, 0.6f, 0.45f, 1.5f);
}

void bedroom(Builder& b) {
  Pcg32& r = b.rng();
  const float height = r.uniform(2.4f, 2.7f);  // drawn last to first (see Builder::vary)
  const float depth = r.uniform(4.5f, 5.5f);
  const float width = r.uniform(4.2f, 5.5f);
  b.shell(Vec3(width, depth, height));
  const int head = static_cast<int>(r.below(4));
  const float bw = r.uniform(1.4f, 1.8f);
  Placement pl;
  if (b.find_wall_spot(head, bw, 2.0f, 0, 1.1f, 0.0f, pl)) {
    b.bed(pl, bw, 2.0f);
    for (int side = -1; side <= 1; side += 2) {
      Placement ns = pl;
      ns.origin += rotate(pl.yaw, Vec2(side * (bw / 2 + 0.3f), -1.0f + 0.22f));
      if (b.is_free(ns, Vec3(0, 0, 0.3f), Vec3(0.24f, 0.22f, 0.3f))) {
        b.cabinet(ns, 0.45f, 0.4f, 0.55f);
        if (side < 0) b.lamp(ns, 0.55f, 0.3f); else b.clutter(ns, Vec2(0, 0), Vec2(0.1f, 0.08f), 0.55f, 2);
        b.reserve(ns, Vec3(0, 0, 0.3f), Vec3(0.24f, 0.22f, 0.3f));
      }
    }
  }
  b.painting(head, r.uniform(0.8f, 1.2f), 0.5f, 1.65f);
  if (b.find_any_wall_spot(head + 1, 1.6f, 0.6f, 0, 2.2f, 0.02f, pl)) b.wardrobe(pl, 1.6f);
  if (b.find_any_wall_spot(head + 3, 1.2f, 0.6f, 0, 1.1f, 0.02f, pl)) {
    b.table(pl, 1.1f, 0.55f, 0.75f);
    b.clutter(pl, Vec2(0, 0), Vec2(0.4f, 0.15f), 0.75f, 2);
    Placement ch = pl;
    ch.origin += rotate(pl.yaw, Vec2(0.1f, 0.55f));
    ch.yaw += kPi + 0.3f;
    if (b.is_free(ch, Vec3(0, 0, 0.5f), Vec3(0.25f, 0.25f, 0.5f))) {
      b.chair(ch);
      b.reserve(ch, Vec3(0, 0, 0.5f), Vec3(0.25f, 0.25f, 0.5f));
    }
  }
  if (b.find_any_wall_spot(head + 2, 1.2f, 0.45f, 0, 1.0f, 0.02f, pl)) {
    b.cabinet(pl, 1.2f, 0.45f, 0.8f);
    b.tv(pl, 0.8f, 0.8f);
  }
  b.window(head + 2, r.uniform(1.0f, 1.5f), 1.2f);
  b.window(head + 1, 1.0f, 1.2f);
}

void office(Builder& b) {
  Pcg32& r = b.rng();
  const float height = r.uniform(2.5f, 3.0f);  // drawn last to first (see Builder::vary)
  const float depth = r.uniform(3.8f, 5.0f);
  const float width = r.uniform(4.0f, 5.5f);
  b.shell(Vec3(width, depth, height));
  Placement pl;
  for (int i = 0; i < 2; ++i) {
    const float w = r.uniform(1.3f, 1.7f);
    if (!b.find_any_wall_spot(i * 2, w, 0.75f, 0, 1.3f, 0.02f, pl)) continue;
    b.table(pl, w, 0.75f, 0.74f);
    b.tv(pl, 0.74f, 0.55f);
    Placement kb = pl;
    b.part(kb, Vec3(0, 0.2f, 0.755f), Vec3(0.22f, 0.07f, 0.015f), kObjects, b.painted());
    b.clutter(pl, Vec2(w / 2 - 0.2f, 0), Vec2(0.1f, 0.2f), 0.74f, 2);
    Placement ch = pl;
    ch.origin += rotate(pl.yaw, Vec2(r.uniform(-0.2f, 0.2f), 0.7f));
    ch.yaw += kPi + r.uniform(-0.4f, 0.4f);
    if (b.is_free(ch, Vec3(0, 0, 0.5f), Vec3(0.25f, 0.25f, 0.5f))) {
      b.chair(ch);
      b.reserve(ch, Vec3(0, 0, 0.5f), Vec3(0.25f, 0.25f, 0.5f));
    }
  }
  for (int i = 0; i < 2; ++i)
    if (b.find_any_wall_spot(1 + i * 2, 0.9f, 0.32f, 0, 2.0f, 0.02f, pl)) b.bookshelf(pl, 0.9f, r.uniform(1.7f, 2.0f));
  if (b.find_any_wall_spot(3, 0.8f, 0.45f, 0, 1.1f, 0.02f, pl)) {
    b.cabinet(pl, 0.8f, 0.45f, 1.0f);
    b.clutter(pl, Vec2(0, 0), Vec2(0.3f, 0.1f), 1.0f, 2);
  }
  if (b.find_any_wall_spot(1, 0.6f, 0.6f, 0, 1.0f, 0.05f, pl)) b.plant(pl);
  b.window(1, r.uniform(1.2f, 1.8f), 1.3f);
  b.painting(3, 0.9f, 0.6f, 1.6f);
  b.painting(2, 0.5f, 0.7f, 1.6f);
}

void kitchen(Builder& b) {
  Pcg32& r = b.rng();
  const float height = r.uniform(2.4f, 2.8f);  // drawn last to first (see Builder::vary)
  const float depth = r.uniform(3.8f, 4.8f);
  const float width = r.uniform(4.5f, 6.0f);
  b.shell(Vec3(width, depth, height));
  Placement pl;
  // A run of counters (furniture) with clutter, and wall cabinets above.
  const float run = std::min(b.W() - 0.4f, r.uniform(2.4f, 3.2f));
  if (b.find_wall_spot(0, run, 0.6f, 0, 2.3f, 0.0f, pl)) {
    b.cabinet(pl, run, 0.6f, 0.9f);
    b.part(pl, Vec3(0, 0.02f, 0.92f), Vec3(run / 2 + 0.02f, 0.31f, 0.02f), kFurniture,
           b.mat(TextureKind::kTiles, Vec3(0.8f, 0.8f, 0.78f), Vec3(0.4f, 0.4f, 0.4f), 0.1f));
    b.clutter(pl, Vec2(0, 0.05f), Vec2(run / 2 - 0.2f, 0.15f), 0.94f, 5);
    Placement upper = pl;
    upper.origin += rotate(pl.yaw, Vec2(0, -0.12f));
    Material m = b.painted();
    b.part(upper, Vec3(0, 0, 1.85f), Vec3(run / 2, 0.18f, 0.35f), kFurniture, m);
  }
  // Dining table with chairs, one long side towards wall 2.
  const float tw = r.uniform(1.2f, 1.6f);
  if (b.find_wall_spot(2, tw + 1.0f, 1.6f, 0, 1.0f, 0.2f, pl)) {
    Placement t = pl;
    t.origin += rotate(pl.yaw, Vec2(0, 0.2f));
    b.table(t, tw, 0.85f, 0.75f);
    b.clutter(t, Vec2(0, 0), Vec2(tw / 2 - 0.15f, 0.25f), 0.75f, 4);
    for (int i = 0; i < 4; ++i) {
      Placement c = t;
      const Vec2 off = i < 2 ? Vec2((i == 0 ? -1 : 1) * tw * 0.25f, -0.6f) : Vec2((i == 2 ? -1 : 1) * (tw / 2 + 0.35f), 0.0f);
      const float yaw = i < 2 ? 0.0f : (i == 2 ? -kPi / 2 : kPi / 2);
      c.origin += rotate(t.yaw, off);
      c.yaw += yaw + r.uniform(-0.2f, 0.2f);
      b.chair(c);
    }
  }
  if (b.find_any_wall_spot(1, 0.8f, 0.65f, 0, 1.9f, 0.02f, pl)) b.cabinet(pl, 0.8f, 0.65f, 1.85f);  // fridge
  b.window(0, r.uniform(0.9f, 1.3f), 1.0f);
  b.window(3, r.uniform(1.0f, 1.4f), 1.2f);
  b.painting(1, 0.7f, 0.5f, 1.6f);
  if (b.find_any_wall_spot(3, 0.4f, 0.4f, 0, 1.9f, 0.05f, pl)) b.lamp(pl, 0, 1.5f);
  if (b.find_any_wall_spot(1, 0.9f, 0.4f, 0, 1.3f, 0.02f, pl)) {
    b.cabinet(pl, 0.9f, 0.4f, 0.7f);
    b.tv(pl, 0.7f, 0.6f);
  }
}

void library(Builder& b) {
  Pcg32& r = b.rng();
  const float height = r.uniform(2.7f, 3.0f);  // drawn last to first (see Builder::vary)
  const float depth = r.uniform(4.5f, 5.5f);
  const float width = r.uniform(5.0f, 6.5f);
  b.shell(Vec3(width, depth, height));
  Placement pl;
  for (int wall = 0; wall < 4; ++wall) {
    const int n = wall % 2 == 0 ? 3 : 2;
    for (int i = 0; i < n; ++i)
      if (b.find_wall_spot(wall, 1.0f, 0.32f, 0, 2.2f, 0.02f, pl)) b.bookshelf(pl, 1.0f, r.uniform(1.8f, 2.2f));
  }
  if (b.find_any_wall_spot(2, 1.9f, 0.9f, 0, 1.0f, 0.02f, pl)) b.sofa(pl, 1.9f);
  if (b.find_any_wall_spot(0, 1.4f, 0.7f, 0, 1.0f, 0.02f, pl)) {
    b.table(pl, 1.4f, 0.7f, 0.75f);
    b.clutter(pl, Vec2(0, 0), Vec2(0.5f, 0.2f), 0.75f, 3);
    Placement ch = pl;
    ch.origin += rotate(pl.yaw, Vec2(0, 0.65f));
    ch.yaw += kPi;
    b.chair(ch);
  }
  if (b.find_any_wall_spot(1, 0.85f, 0.85f, 0, 1.0f, 0.1f, pl)) b.armchair(pl);
  b.painting(1, 1.0f, 0.7f, 1.6f);
  b.painting(3, 0.6f, 0.8f, 1.5f);
  b.window(3, 1.2f, 1.3f);
  if (b.find_any_wall_spot(2, 0.4f, 0.4f, 0, 1.9f, 0.05f, pl)) b.lamp(pl, 0, 1.5f);
}

void build_kind(RoomKind kind, Builder& b) {
  switch (kind) {
    case RoomKind::kLiving: living_room(b); break;
    case RoomKind::kBedroom: bedroom(b); break;
    case RoomKind::kOffice: office(b); break;
    case RoomKind::kKitchen: kitchen(b); break;
    case RoomKind::kLibrary: library(b); break;
  }
}

struct NamedRoom {
  const char* name;
  RoomKind kind;
  uint32_t seed;  // fixed: a built-in room never changes with the user's seed
};
constexpr NamedRoom kRooms[] = {
    {"living_room", RoomKind::kLiving, 11}, {"bedroom", RoomKind::kBedroom, 23}, {"office", RoomKind::kOffice, 37},
    {"kitchen", RoomKind::kKitchen, 41},    {"library", RoomKind::kLibrary, 59},
};

}  // namespace

const std::vector<std::string>& builtin_room_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> v;
    for (const NamedRoom& r : kRooms) v.emplace_back(r.name);
    return v;
  }();
  return names;
}

Result<Scene> build_room(const std::string& name, uint32_t seed, RoomLayout layout, TrajectoryKind path) {
  const std::string wanted = name.empty() ? kRooms[0].name : name;
  RoomKind kind = RoomKind::kLiving;
  uint32_t room_seed = 0;
  if (name == "random") {
    room_seed = hash32(seed, 0x7200u);
    kind = static_cast<RoomKind>(room_seed % 5);
  } else {
    bool known = false;
    for (const NamedRoom& r : kRooms) {
      if (wanted != r.name) continue;
      known = true;
      kind = r.kind;
      room_seed = r.seed;
    }
    if (!known) {
      std::string list;
      for (const NamedRoom& r : kRooms) list += std::string(list.empty() ? "" : ", ") + r.name;
      return error(ErrorCode::kInvalidArgument,
                   "synthetic: unknown room '" + name + "' (known: " + list + ", random)");
    }
  }
  Scene scene;
  Builder b(scene, room_seed);
  build_kind(kind, b);
  scene.name = name == "random" ? "random" : wanted;
  if (layout == RoomLayout::kWalls) return scene;
  // The middle group goes where the camera's path through the room without it does not: the
  // trajectory stays the same, and the camera never passes through the group. 0.4 m is more
  // than the hand-held loop's clearance (0.33 m to any surface) and the robot's radius (0.3 m);
  // the hand-held camera may pass over the group, the robot must drive round it.
  TrajectoryOptions t;
  t.kind = path;
  t.seed = seed;
  EF_ASSIGN_OR_RETURN(const std::vector<Vec3> lap, trajectory_lap(scene, t));
  if (!b.island(lap, 0.4f, is_handheld(path)))
    return error(ErrorCode::kInvalidArgument, "synthetic: no furniture group fits in the middle of room '" + wanted +
                                                  "' (seed " + std::to_string(seed) +
                                                  ") clear of the camera's path; try layout=walls or another seed");
  return scene;
}

}  // namespace ef::synth
