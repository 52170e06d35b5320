// The built-in synthetic source with its scene and poses (synth::SyntheticSource), opened from a URI,
// for the SLAM tests that render views of their own or read frames out of order.
#pragma once

#include <memory>
#include <string>

#include <gtest/gtest.h>

#include "io/frame_source.h"
#include "synth/synthetic_source.h"

namespace ef::test {

// Opens `uri` ("synthetic:ROOM?..."); a failure is a test failure naming the reason, and nullptr.
inline std::unique_ptr<synth::SyntheticSource> open_synthetic(const std::string& uri) {
  auto parsed = parse_source_uri(uri);
  EXPECT_TRUE(parsed.ok()) << uri << ": " << to_string(parsed.error());
  if (!parsed.ok()) return nullptr;
  auto options = synth::parse_synthetic_options(*parsed);
  EXPECT_TRUE(options.ok()) << uri << ": " << to_string(options.error());
  if (!options.ok()) return nullptr;
  auto src = synth::open_synthetic_source(*options, uri);
  EXPECT_TRUE(src.ok()) << uri << ": " << to_string(src.error());
  if (!src.ok()) return nullptr;
  return std::move(src).value();
}

}  // namespace ef::test
