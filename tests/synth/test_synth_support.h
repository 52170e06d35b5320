// Helpers for the synthetic-source tests.
#pragma once

#include <memory>
#include <string>

#include <gtest/gtest.h>

#include "io/frame_source.h"
#include "synth/synthetic_source.h"

namespace ef::test {

// Opens a synthetic source from a URI text ("synthetic:room?k=v"), failing the test on error.
inline std::unique_ptr<synth::SyntheticSource> open_synth(const std::string& text) {
  auto uri = parse_source_uri(text);
  EXPECT_TRUE(uri.ok()) << text << ": " << (uri.ok() ? "" : to_string(uri.error()));
  if (!uri.ok()) return nullptr;
  auto options = synth::parse_synthetic_options(*uri);
  EXPECT_TRUE(options.ok()) << text << ": " << (options.ok() ? "" : to_string(options.error()));
  if (!options.ok()) return nullptr;
  auto src = synth::open_synthetic_source(*options, text);
  EXPECT_TRUE(src.ok()) << text << ": " << (src.ok() ? "" : to_string(src.error()));
  if (!src.ok()) return nullptr;
  return std::move(src).value();
}

}  // namespace ef::test
