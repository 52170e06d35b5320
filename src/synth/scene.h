// Description of one synthetic room: the room box, the objects in it, their materials and lights.
//
// World frame of a room: x along the room's width, y along its depth, z up, metres; the floor is
// z = 0 and the room spans [0, size.x] x [0, size.y] x [0, size.z]. Every object is a primitive
// (an oriented box, a vertical cylinder or a sphere) rotated by a yaw about the vertical.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/classes.h"

namespace ef::synth {

enum class Shape : uint8_t { kBox, kCylinder, kSphere };

// Procedural pattern of a surface (evaluated in materials.cpp).
enum class TextureKind : uint8_t {
  kPlain,       // base colour with a faint low-frequency mottle
  kPlaster,     // walls and ceilings: mottle plus fine grain
  kWallpaper,   // vertical stripes with a small repeating motif
  kWood,        // wood grain along the surface's u axis
  kPlanks,      // floor boards: staggered planks of wood, dark seams
  kFabric,      // woven cloth: noise and a fine weave
  kTiles,       // square tiles with grout lines
  kStripes,     // bands of base and accent colour
  kBookSpines,  // a row of book spines of varied colours with title bands
  kSky,         // a window: sky and clouds, white frame and cross bars
  kPainting,    // a framed colourful picture
  kScreen,      // a tv: black bezel around a dim picture
};

struct Material {
  Eigen::Vector3f base{0.6f, 0.6f, 0.6f};    // linear albedo, each channel in [0, 1]
  Eigen::Vector3f accent{0.3f, 0.3f, 0.3f};  // the pattern's second colour, linear [0, 1]
  TextureKind texture = TextureKind::kPlain;
  float scale = 0.1f;     // metres per pattern period (tile, stripe, plank width, grain)
  float emission = 0.0f;  // [0, 1]: share of the colour that is self-lit (sky, screens)
  uint32_t seed = 0;      // per-surface variation of the pattern
};

struct Primitive {
  Shape shape = Shape::kBox;
  Eigen::Vector3f center{0, 0, 0};  // world, metres
  // Box: half extents along its own x, y, z (metres). Cylinder (axis vertical): (radius, radius,
  // half height). Sphere: (radius, radius, radius).
  Eigen::Vector3f half{0.1f, 0.1f, 0.1f};
  float yaw = 0;      // rotation about world z, radians (object x axis -> world (cos, sin, 0))
  float cos_yaw = 1;  // cached cos(yaw), set by Scene::add
  float sin_yaw = 0;  // cached sin(yaw)
  uint8_t label = kUnknown;  // class id, core/classes.h
  Material material;

  // World point into the primitive's own frame (centred, unrotated). Out of line (scene.cpp, no
  // fused multiply-add) so that every caller gets the same bits on every ISA.
  Eigen::Vector3f to_local(const Eigen::Vector3f& p) const;
  // Direction from the primitive's frame into the world frame.
  Eigen::Vector3f dir_to_world(const Eigen::Vector3f& d) const;
  // Signed distance from a point in the primitive's frame to its surface (negative inside), metres.
  float local_signed_distance(const Eigen::Vector3f& q) const;
};

struct Light {
  Eigen::Vector3f position{0, 0, 2.5f};   // world, metres
  Eigen::Vector3f color{1, 1, 1};         // linear intensity per channel at distance 0
  float falloff = 3.0f;                   // metres: intensity halves at this distance
};

// Result of a ray cast.
struct Hit {
  float t = 0;                 // ray parameter at the hit (distance in units of |d|)
  Eigen::Vector3f normal{0, 0, 1};  // world unit normal, facing the ray's origin side
  uint8_t label = kUnknown;
  int surface = -1;            // >= 0: primitive index; -1 - face for room faces (see RoomFace)
};

// The six faces of the room box, as seen from inside.
enum RoomFace : int { kFloorFace = 0, kCeilingFace, kWallYMin, kWallXMax, kWallYMax, kWallXMin };

struct Scene {
  std::string name;
  Eigen::Vector3f size{5, 4, 2.6f};     // room width (x), depth (y), height (z), metres
  Material face_material[6];            // indexed by RoomFace
  std::vector<Primitive> primitives;
  std::vector<Light> lights;
  Eigen::Vector3f ambient{0.25f, 0.25f, 0.25f};  // linear ambient light

  // Adds a primitive, caching its yaw's sine and cosine (det_math.h: the same bits on every
  // machine); returns its index.
  int add(Primitive p);

  // Unsigned distance from a world point to the nearest surface (room faces or object), metres.
  float distance_to_surface(const Eigen::Vector3f& p) const;
  // Signed distance to occupied space: positive in free space inside the room, negative inside an
  // object or outside the room, metres.
  float free_space_distance(const Eigen::Vector3f& p) const;
  // Horizontal clearance of a robot lower than z_max (metres) moving on the floor: the distance in
  // the floor plane to the walls and to the footprint of every object that starts below z_max and
  // is more than 3 cm tall (rugs are driven over), metres.
  float floor_clearance(const Eigen::Vector3f& p, float z_max) const;

  // Brute-force ray cast (every primitive): the nearest hit with t > t_min, if any. The reference
  // for tests; the renderer (renderer.h) is the fast path.
  bool raycast(const Eigen::Vector3f& origin, const Eigen::Vector3f& dir, Hit& hit, float t_min = 1e-4f) const;

  // Labels present among the room's surfaces and objects (index = class id).
  std::vector<bool> classes_present() const;
};

// Ray/primitive intersection in the primitive's local frame: the entry (or, from inside, exit)
// parameter t > t_min, and the local-frame normal of the face hit. Shared by the renderer.
bool intersect_local(const Primitive& p, const Eigen::Vector3f& o, const Eigen::Vector3f& d, float t_min,
                     float& t, Eigen::Vector3f& n_local);

}  // namespace ef::synth
