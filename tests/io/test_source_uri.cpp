#include <gtest/gtest.h>

#include "io/frame_source.h"
#include "io_test_util.h"

namespace ef {
namespace {

TEST(SourceUri, ParsesSchemePathAndQuery) {
  auto r = parse_source_uri("klg:/data/log.klg?size=320x240&fx=262.5");
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->scheme, "klg");
  EXPECT_EQ(r->path, "/data/log.klg");
  ASSERT_EQ(r->query.size(), 2u);
  EXPECT_EQ(r->query.at("size"), "320x240");
  EXPECT_EQ(r->query.at("fx"), "262.5");
}

TEST(SourceUri, EmptyPathAndNoQuery) {
  auto r = parse_source_uri("synthetic:");
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->scheme, "synthetic");
  EXPECT_TRUE(r->path.empty());
  EXPECT_TRUE(r->query.empty());
  auto r2 = parse_source_uri("7scenes:../d/x?");
  ASSERT_TRUE(r2.ok());
  EXPECT_EQ(r2->path, "../d/x");
  auto r3 = parse_source_uri("tum:dir?k=");
  ASSERT_TRUE(r3.ok());
  EXPECT_EQ(r3->query.at("k"), "");
}

TEST(SourceUri, MalformedUrisAreErrorsNamingTheProblem) {
  EXPECT_ERROR_WITH(parse_source_uri("/data/log.klg"), ErrorCode::kInvalidArgument, "no scheme", "/data/log.klg");
  EXPECT_ERROR_WITH(parse_source_uri(":x"), ErrorCode::kInvalidArgument, "empty scheme");
  EXPECT_ERROR_WITH(parse_source_uri("k g:x"), ErrorCode::kInvalidArgument, "scheme 'k g'");
  EXPECT_ERROR_WITH(parse_source_uri("tum:d?=3"), ErrorCode::kInvalidArgument, "empty key");
  EXPECT_ERROR_WITH(parse_source_uri("tum:d?fx=1&fx=2"), ErrorCode::kInvalidArgument, "'fx' given twice");
  EXPECT_ERROR_WITH(parse_source_uri("tum:d?fx"), ErrorCode::kInvalidArgument, "'fx' has no '='");
  EXPECT_ERROR_WITH(parse_source_uri("tum:d?fx=1&&fy=2"), ErrorCode::kInvalidArgument, "empty option");
}

TEST(SourceUri, UnknownQueryKeyNamesKeyAndScheme) {
  auto r = parse_source_uri("tum:d?fx=1&colour=no");
  ASSERT_TRUE(r.ok());
  EXPECT_TRUE(check_query_keys(*r, {"fx", "colour"}).ok());
  EXPECT_ERROR_WITH(check_query_keys(*r, {"fx", "fy"}), ErrorCode::kInvalidArgument, "'colour'", "'tum'", "fx, fy");
}

}  // namespace
}  // namespace ef
