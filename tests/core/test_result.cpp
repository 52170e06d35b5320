#include <gtest/gtest.h>

#include "core/result.h"

namespace ef {
namespace {

Result<int> parse_positive(int v) {
  if (v <= 0) return error(ErrorCode::kInvalidArgument, "value " + std::to_string(v) + " is not positive");
  return v;
}

Result<int> doubled(int v) {
  EF_ASSIGN_OR_RETURN(int x, parse_positive(v));
  return 2 * x;
}

Status check(int v) {
  EF_RETURN_IF_ERROR(parse_positive(v));
  return Status::success();
}

TEST(Result, CarriesValueOrError) {
  auto ok = parse_positive(3);
  ASSERT_TRUE(ok.ok());
  EXPECT_EQ(*ok, 3);
  auto bad = parse_positive(-1);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code, ErrorCode::kInvalidArgument);
  EXPECT_EQ(to_string(bad.error()), "invalid argument: value -1 is not positive");
}

TEST(Result, MacrosPropagate) {
  EXPECT_EQ(*doubled(4), 8);
  EXPECT_FALSE(doubled(0).ok());
  EXPECT_TRUE(check(1).ok());
  EXPECT_EQ(check(-2).error().code, ErrorCode::kInvalidArgument);
}

}  // namespace
}  // namespace ef
