// Strict comma-separated number parsing used by every command-line and URL parameter.
#include <gtest/gtest.h>

#include "pbdam/formats/NumberList.h"

using namespace pbdam::formats;

namespace pbdam::formats {
namespace {

TEST(NumberList, ParsesExactlyTheExpectedCount) {
  std::vector<double> v;
  ASSERT_TRUE(parseNumberList("17.375,-133.125", 2, v));
  EXPECT_DOUBLE_EQ(v[0], 17.375);
  EXPECT_DOUBLE_EQ(v[1], -133.125);
  ASSERT_TRUE(parseNumberList("-90,0,90,360", 4, v));
  EXPECT_DOUBLE_EQ(v[3], 360.0);
}

TEST(NumberList, RejectsMalformedText) {
  std::vector<double> v;
  for (const char* bad :
       {"", "1", "1,", ",1", "1,2,3", "a,b", "1,2x", "nan,1", "inf,2", "1;2", " 1,2", "1e999,0"}) {
    EXPECT_FALSE(parseNumberList(bad, 2, v)) << bad;
  }
}

}  // namespace
}  // namespace pbdam::formats
