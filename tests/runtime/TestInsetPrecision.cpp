// Camera-relative precision over a lidar-class inset built here: the lattice of a 1 m inset on
// ETOPO5 has 2^24 cells a face side and its leaves are 40 levels deep, the finest the format
// holds. A binary of its own because it runs the (TBB-parallel) builder in process, which the
// ThreadSanitizer preset leaves out with the other builder tests (tests/sanitizers/tsan.supp).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "CameraPrecision.h"
#include "TestData.h"
#include "pbdam/builder/Builder.h"
#include "pbdam/formats/DemReader.h"

namespace pbdam::runtime {
namespace {

using formats::readDem;
using formats::TexelFormat;
using precision::measurePrecision;
using precision::PrecisionFigures;

TEST(CameraRelative, MillimetreAccurateTwoMetresAboveAOneMetreInset) {
  // Lidar class: 200 x 200 samples of a geographic grid 1 m apart north-south (0.65 m east-west;
  // the Luxembourg DEM with metre-scale detail added) on ETOPO5, so the lattice has 2^24 cells a
  // face side and the inset's leaves are 40 levels deep, their vertices 2^-24 of a face apart.
  PBDAM_REQUIRE_DATA(etopo5, PBDAM_ETOPO5_PATH);
  PBDAM_REQUIRE_DATA(luxembourg, test::dataDir() / "geotiff/terra_elev_luxembourg.tif");
  auto lux = readDem(luxembourg);
  ASSERT_TRUE(lux.ok()) << lux.error().message;
  test::TempDir dir;
  constexpr int kSide = 200;
  constexpr double kLat = 49.80;  // the inset's south-west corner
  constexpr double kLon = 6.05;
  const double dLat = 1.0 / 111250.0;  // 1 m north-south at 49.8°N
  const double dLon = dLat;
  const std::filesystem::path fine = dir / "lux_1m.asc";
  {
    std::ofstream out(fine);
    out.precision(12);
    out << "ncols " << kSide << "\nnrows " << kSide << "\nxllcorner " << kLon << "\nyllcorner "
        << kLat << "\ncellsize " << dLat << "\nNODATA_value -9999\n";
    out.precision(9);
    for (int r = 0; r < kSide; ++r) {
      for (int c = 0; c < kSide; ++c) {
        const double lat = kLat + (kSide - r - 0.5) * dLat;
        const double lon = kLon + (c + 0.5) * dLon;
        const double detail =
            2.0 * std::sin(0.37 * c) * std::cos(0.23 * r) + 0.5 * std::sin(1.9 * c + 1.3 * r);
        out << lux->sampleBilinear(lat, lon).value_or(300.0) + detail
            << (c + 1 < kSide ? " " : "\n");
      }
    }
    std::ofstream prj(dir / "lux_1m.prj");
    prj << R"(GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563]],)"
        << R"(PRIMEM["Greenwich",0],UNIT["degree",0.0174532925199433]])";
  }
  builder::BuildOptions o;
  o.demPath = etopo5;
  o.planetSpec = "earth";
  o.outDir = dir / "lidar";
  o.leafVertices = 17;
  o.minPatchTriangles = 128;
  o.depth = 4;
  o.textureTileTexels = 64;
  o.textureFormat = TexelFormat::Rgba8;
  o.threads = 2;
  o.insets = {builder::InsetSpec{fine, {}, {}}};
  auto summary = builder::buildDataset(o);
  ASSERT_TRUE(summary) << summary.error().message;
  EXPECT_EQ(summary->latticeCells, 1u << 24);
  EXPECT_EQ(summary->depth, 40u);
  const PrecisionFigures f =
      measurePrecision(dir / "lidar", kLat + 0.5 * kSide * dLat, kLon + 0.5 * kSide * dLon, 300.0);
  ASSERT_GT(f.vertices, 0u);
  EXPECT_LE(f.cameraRelative, 1e-3);
  EXPECT_GT(f.absoluteFloat, 0.1);  // the test fails without the technique
}

}  // namespace
}  // namespace pbdam::runtime
