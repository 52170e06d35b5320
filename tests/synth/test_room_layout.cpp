// RoomLayout::kIsland: a group of furniture in the middle of the room that leaves the room
// around it and the camera's path as they were, keeps its distance from that path, and hides a
// part of the room that changes from view to view.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/classes.h"
#include "synth/room_builder.h"
#include "synth/synthetic_source.h"
#include "synth/trajectory.h"
#include "test_synth_support.h"

namespace ef {
namespace {

using synth::RoomLayout;
using synth::Scene;
using synth::TrajectoryKind;

// The same primitive, field by field (bit for bit: both rooms come from the same draws).
bool same_primitive(const synth::Primitive& a, const synth::Primitive& b) {
  return a.shape == b.shape && a.center == b.center && a.half == b.half && a.yaw == b.yaw && a.label == b.label &&
         a.material.texture == b.material.texture && a.material.base == b.material.base &&
         a.material.seed == b.material.seed;
}

// Checks one room in both layouts for one path kind; returns false when no group fits (the
// error must then say so and point to layout=walls).
bool check_island(const std::string& room, uint32_t seed, TrajectoryKind kind) {
  const std::string what = room + " seed " + std::to_string(seed) + (kind == TrajectoryKind::kLoop ? " loop" : " robot");
  auto walls = synth::build_room(room, seed, RoomLayout::kWalls, kind);
  auto island = synth::build_room(room, seed, RoomLayout::kIsland, kind);
  EXPECT_TRUE(walls.ok()) << what;
  if (!walls.ok()) return false;
  if (!island.ok()) {
    const std::string message = to_string(island.error());
    EXPECT_NE(message.find("no furniture group fits"), std::string::npos) << message;
    EXPECT_NE(message.find("layout=walls"), std::string::npos) << message;
    return false;
  }
  // The room along the walls is untouched: the island scene starts with the same primitives, the
  // same size and lights, and adds a few.
  const auto& a = walls->primitives;
  const auto& b = island->primitives;
  EXPECT_EQ(walls->size, island->size) << what;
  EXPECT_EQ(walls->lights.size(), island->lights.size()) << what;
  EXPECT_GE(b.size(), a.size() + 1) << what;
  EXPECT_LE(b.size(), a.size() + 60) << what;
  for (std::size_t i = 0; i < std::min(a.size(), b.size()); ++i)
    EXPECT_TRUE(same_primitive(a[i], b[i])) << what << ": primitive " << i << " changed";
  // The new ones stand near the middle (the group is at most 0.6 m off the centre and about
  // 2.5 m across) on the floor.
  const Eigen::Vector2f centre = island->size.head<2>() / 2;
  for (std::size_t i = a.size(); i < b.size(); ++i) {
    EXPECT_LT((b[i].center.head<2>() - centre).norm(), 2.0f) << what << ": primitive " << i;
    EXPECT_GE(b[i].center.z() - b[i].half.z(), -1e-4f) << what << ": primitive " << i << " below the floor";
  }
  // The camera's path is the same in both rooms, and clear of the group: the hand-held camera
  // keeps the loop's own 0.33 m from every surface, the robot 0.3 m from every footprint.
  synth::TrajectoryOptions t;
  t.kind = kind;
  t.seed = seed;
  t.frames = 300;
  auto poses_walls = synth::make_trajectory(*walls, t);
  auto poses_island = synth::make_trajectory(*island, t);
  EXPECT_TRUE(poses_walls.ok() && poses_island.ok()) << what;
  if (!poses_walls.ok() || !poses_island.ok()) return true;
  EXPECT_EQ(poses_walls->size(), poses_island->size());
  for (std::size_t i = 0; i < std::min(poses_walls->size(), poses_island->size()); ++i) {
    const Eigen::Vector3d p = (*poses_island)[i].translation();
    EXPECT_EQ((*poses_walls)[i].translation(), p) << what << ": frame " << i;
    if (kind == TrajectoryKind::kLoop)
      EXPECT_GT(island->free_space_distance(p.cast<float>()), 0.33f) << what << ": frame " << i;
    else
      EXPECT_GT(island->floor_clearance(p.cast<float>(), 0.9f), 0.3f) << what << ": frame " << i;
  }
  return true;
}

TEST(RoomLayout, IslandAddsAGroupInTheMiddleAndKeepsTheRoomAndThePath) {
  // Every built-in room, and random rooms of every kind, with the hand-held loop: a group fits in
  // all of them (in 100 random seeds, all fitted when this was written).
  for (const std::string& room : synthetic_room_names()) EXPECT_TRUE(check_island(room, 0, TrajectoryKind::kLoop)) << room;
  for (uint32_t seed = 0; seed < 8; ++seed) EXPECT_TRUE(check_island("random", seed, TrajectoryKind::kLoop)) << seed;
  // The robot drives round the group where it fits; where the path crosses the middle the
  // answer is the error checked inside (about a third of rooms).
  int fitted = 0;
  for (uint32_t seed = 0; seed < 8; ++seed) fitted += check_island("random", seed, TrajectoryKind::kRobot);
  EXPECT_GE(fitted, 3);
}

TEST(RoomLayout, IslandVariantsCoverTheirClasses) {
  // Over random rooms the middle group takes each of its forms: a dining or low table (table,
  // objects), chairs, a free-standing sofa, shelves with books, a counter (furniture).
  std::vector<int> seen(kNumClassesWithUnknown, 0);
  for (uint32_t seed = 0; seed < 60; ++seed) {
    auto walls = synth::build_room("random", seed);
    auto island = synth::build_room("random", seed, RoomLayout::kIsland);
    ASSERT_TRUE(walls.ok() && island.ok()) << seed;
    std::vector<bool> here(kNumClassesWithUnknown, false);
    for (std::size_t i = walls->primitives.size(); i < island->primitives.size(); ++i)
      here[island->primitives[i].label] = true;
    for (int c = 0; c < kNumClassesWithUnknown; ++c) seen[c] += here[c];
  }
  for (int c : {kTable, kObjects, kChair, kSofa, kBooks, kFurniture})
    EXPECT_GE(seen[c], 3) << class_name(c) << " in only " << seen[c] << " of 60 middle groups";
}

TEST(RoomLayout, SourceKeyRendersTheGroupAndHidesAChangingPartOfTheRoom) {
  auto walls = test::open_synth("synthetic:random?seed=5&frames=300&size=80x60&noise=0");
  auto same = test::open_synth("synthetic:random?seed=5&frames=300&size=80x60&noise=0&layout=walls");
  auto island = test::open_synth("synthetic:random?seed=5&frames=300&size=80x60&noise=0&layout=island");
  ASSERT_TRUE(walls && same && island);
  EXPECT_EQ(island->options().layout, RoomLayout::kIsland);
  Frame fw, fs, fi;
  // Where the labels differ between the layouts, the group stands in front of the room; over the
  // loop that part must be sizeable and move (the group hides different things in different views).
  std::vector<double> hidden;
  std::vector<uint8_t> first_mask;
  double changed_mask = 0;
  for (int64_t i = 0; i < 300; i += 60) {
    ASSERT_TRUE(walls->render(i, fw).ok());
    ASSERT_TRUE(same->render(i, fs).ok());
    ASSERT_TRUE(island->render(i, fi).ok());
    ASSERT_EQ(0, std::memcmp(fw.color.data(), fs.color.data(), fw.color.size() * sizeof(Rgb8))) << "layout=walls is the default";
    ASSERT_EQ(0, std::memcmp(fw.labels.data(), fs.labels.data(), fw.labels.size()));
    EXPECT_EQ(fw.T_wc.translation(), fi.T_wc.translation()) << "the same path in both layouts";
    std::vector<uint8_t> mask(fw.labels.size());
    int differ = 0, nearer = 0;
    for (std::size_t p = 0; p < mask.size(); ++p) {
      mask[p] = fw.labels.data()[p] != fi.labels.data()[p];
      differ += mask[p];
      // Where the group is seen, it is in front of what the room without it showed there.
      nearer += mask[p] && fi.depth.data()[p] > 0 && fi.depth.data()[p] < fw.depth.data()[p] + 1e-4f;
    }
    hidden.push_back(static_cast<double>(differ) / static_cast<double>(mask.size()));
    EXPECT_GE(nearer, differ * 9 / 10) << "frame " << i;
    if (first_mask.empty()) {
      first_mask = mask;
    } else {
      int moved = 0;
      for (std::size_t p = 0; p < mask.size(); ++p) moved += mask[p] != first_mask[p];
      changed_mask += static_cast<double>(moved) / static_cast<double>(mask.size());
    }
  }
  std::sort(hidden.begin(), hidden.end());
  const double median_hidden = hidden[hidden.size() / 2];
  std::printf("  middle group covers %.1f%% of the view (median of 5 frames); mask moves %.1f%% per frame\n",
              100 * median_hidden, 100 * changed_mask / 4);
  EXPECT_GT(median_hidden, 0.05);
  EXPECT_GT(changed_mask / 4, 0.05);
}

TEST(RoomLayout, BadLayoutValueIsAnErrorNamingIt) {
  auto uri = parse_source_uri("synthetic:random?layout=middle");
  ASSERT_TRUE(uri.ok());
  auto options = synth::parse_synthetic_options(*uri);
  ASSERT_FALSE(options.ok());
  const std::string message = to_string(options.error());
  EXPECT_NE(message.find("layout"), std::string::npos) << message;
  EXPECT_NE(message.find("middle"), std::string::npos) << message;
  EXPECT_NE(message.find("walls or island"), std::string::npos) << message;
}

}  // namespace
}  // namespace ef
