// Camera-path CSV files: strict parsing with errors naming file and line, and a write/read round
// trip that gives the same numbers back.
#include <gtest/gtest.h>

#include <fstream>
#include <limits>
#include <string>

#include "TestData.h"
#include "pbdam/formats/CameraPath.h"

using namespace pbdam::formats;

namespace pbdam::formats {
namespace {

constexpr const char* kHeader = "t,lat,lon,alt,heading,pitch,roll\n";

std::string errorOf(std::string_view text) {
  auto r = parseCameraPath(text, "path.csv");
  EXPECT_FALSE(r.ok()) << text;
  return r.ok() ? std::string() : r.error().message;
}

TEST(CameraPath, ParsesRowsWithSpacesAndCrlf) {
  const auto r = parseCameraPath(
      "t, lat, lon, alt, heading, pitch, roll\r\n"
      "0,18.65,226.2,40000,0,-90,0\r\n"
      "\r\n"
      " 0.5 , -4.5e1 , +10 , 2.5e5 , 90 , -30 , 1.25 \r\n",
      "path.csv");
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->size(), 2u);
  EXPECT_EQ((*r)[0], (CameraPathPoint{0.0, 18.65, 226.2, 40000.0, 0.0, -90.0, 0.0}));
  EXPECT_EQ((*r)[1], (CameraPathPoint{0.5, -45.0, 10.0, 250000.0, 90.0, -30.0, 1.25}));
}

TEST(CameraPath, RejectsAMissingOrWrongHeader) {
  EXPECT_NE(errorOf("").find("path.csv:1:"), std::string::npos);
  EXPECT_NE(errorOf("0,1,2,3,4,5,6\n").find("path.csv:1: expected the header"), std::string::npos);
  EXPECT_NE(errorOf("t,lat,lon,alt,heading,pitch\n0,1,2,3,4,5\n").find("path.csv:1:"),
            std::string::npos);
  EXPECT_NE(errorOf("t,lon,lat,alt,heading,pitch,roll\n").find("expected the header"),
            std::string::npos);
}

TEST(CameraPath, RejectsBadRowsNamingTheLine) {
  const std::string header = kHeader;
  EXPECT_NE(errorOf(header).find("no camera poses"), std::string::npos);
  EXPECT_NE(errorOf(header + "0,1,2,3,4,5\n").find("path.csv:2: expected 7"), std::string::npos);
  EXPECT_NE(errorOf(header + "0,1,2,3,4,5,6,7\n").find("got 8 fields"), std::string::npos);
  EXPECT_NE(errorOf(header + "0,1,2,3,4,5,6\n1,1,x,3,4,5,6\n").find("path.csv:3: lon 'x'"),
            std::string::npos);
  EXPECT_NE(errorOf(header + "0,1,2,nan,4,5,6\n").find("alt 'nan' is not a finite number"),
            std::string::npos);
  EXPECT_NE(errorOf(header + "0,1,2,3,inf,5,6\n").find("heading"), std::string::npos);
  EXPECT_NE(errorOf(header + "0,1,2,3,4,5,\n").find("roll ''"), std::string::npos);
  EXPECT_NE(errorOf(header + "0,1,2,3,4,5,6 7\n").find("roll"), std::string::npos);
  EXPECT_NE(errorOf(header + "0,1,2,3,4,5,0x10\n").find("roll"), std::string::npos);
}

TEST(CameraPath, RequiresStrictlyIncreasingTime) {
  const std::string header = kHeader;
  EXPECT_NE(errorOf(header + "0,1,2,3,4,5,6\n0,1,2,3,4,5,6\n")
                .find("path.csv:3: t = 0 does not increase (previous row: t = 0)"),
            std::string::npos);
  EXPECT_NE(errorOf(header + "1,1,2,3,4,5,6\n2,1,2,3,4,5,6\n1.5,1,2,3,4,5,6\n").find("path.csv:4:"),
            std::string::npos);
}

TEST(CameraPath, WriteThenReadGivesTheSamePoints) {
  test::TempDir dir;
  const std::vector<CameraPathPoint> points = {
      {0.0, 18.65, 226.2, 40000.0, 0.0, -90.0, 0.0},
      {1.0 / 3.0, -89.999999, -179.5, 1e7, 359.25, 12.5, -0.1},
      {2.0, 0.1 + 0.2, 1e-300, 0.0, std::numeric_limits<double>::denorm_min(), -90.0, 90.0},
  };
  ASSERT_TRUE(writeCameraPath(dir / "path.csv", points).ok());
  const auto read = readCameraPath(dir / "path.csv");
  ASSERT_TRUE(read.ok()) << read.error().message;
  EXPECT_EQ(*read, points);  // shortest round-trip formatting: bit-exact
  EXPECT_FALSE(std::filesystem::exists(dir / "path.csv.tmp"));
  std::ifstream in(dir / "path.csv");
  std::string first;
  std::getline(in, first);
  EXPECT_EQ(first, std::string(kCameraPathHeader));
}

TEST(CameraPath, MissingFileIsNotFound) {
  test::TempDir dir;
  const auto r = readCameraPath(dir / "nope.csv");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::NotFound);
  EXPECT_NE(r.error().message.find("nope.csv"), std::string::npos);
  const auto bad = readCameraPath(dir.path());  // a directory
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code, ErrorCode::NotFound);
}

TEST(CameraPath, FileErrorsNameThePath) {
  test::TempDir dir;
  {
    std::ofstream out(dir / "bad.csv");
    out << kHeader << "0,1,2,3,4,5,6\n1,1,2,3,4,5\n";
  }
  const auto r = readCameraPath(dir / "bad.csv");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::InvalidArgument);
  EXPECT_NE(r.error().message.find((dir / "bad.csv").string() + ":3:"), std::string::npos)
      << r.error().message;
}

}  // namespace
}  // namespace pbdam::formats
