// Elevation ingest on real data (MOLA MEGDR, ETOPO5, the terra GeoTIFF), synthetic SRTM and UTM
// files written here, and rejection of truncated, corrupt and inconsistent inputs.
#include <gdal.h>
#include <gtest/gtest.h>
#include <ogr_srs_api.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <functional>

#include "TestData.h"
#include "Utm32GeoTiff.h"
#include "pbdam/formats/DemReader.h"

using namespace pbdam::formats;

namespace pbdam::formats {
namespace {

namespace fs = std::filesystem;

constexpr const char* kMolaLabel = "mars/megt90n000cb.lbl";
constexpr const char* kMolaImage = "mars/megt90n000cb.img";
constexpr const char* kMolaRadius = "mars/megr90n000cb.img";

/// `text` with the first occurrence of `from` replaced by `to`.
std::string replaceOnce(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

void writeBytes(const fs::path& p, const std::string& bytes) {
  std::ofstream out(p, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

/// Copies the MOLA label and image into `dir`, the image cut to `imageBytes` (all if < 0) and the
/// label edited by `editLabel`.
fs::path copyMola(const fs::path& dir, std::int64_t imageBytes,
                  const std::function<std::string(std::string)>& editLabel = {}) {
  std::string label = test::readFile(test::dataDir() / kMolaLabel);
  if (editLabel) label = editLabel(label);
  writeBytes(dir / "megt90n000cb.lbl", label);
  std::string image = test::readFile(test::dataDir() / kMolaImage);
  if (imageBytes >= 0) image.resize(static_cast<std::size_t>(imageBytes));
  writeBytes(dir / "megt90n000cb.img", image);
  return dir / "megt90n000cb.lbl";
}

void expectRejected(const Result<HeightGrid>& r, const fs::path& named, const std::string& what) {
  ASSERT_FALSE(r) << "accepted " << named;
  EXPECT_NE(r.error().message.find(named.filename().string()), std::string::npos)
      << r.error().message;
  EXPECT_NE(r.error().message.find(what), std::string::npos) << r.error().message;
}

TEST(DemReader, MolaMegdrIsGeoreferencedLikeItsLabel) {
  PBDAM_REQUIRE_DATA(label, test::dataDir() / kMolaLabel);
  auto grid = readDem(label);
  ASSERT_TRUE(grid) << grid.error().message;
  EXPECT_EQ(grid->width(), 1440);
  EXPECT_EQ(grid->height(), 720);
  EXPECT_EQ(grid->source().body, "mars");
  EXPECT_TRUE(grid->geometry().pixelIsArea);
  // The label: MAXIMUM_LATITUDE 90, WESTERNMOST_LONGITUDE 0, 4 pixels per degree.
  const LatLonBounds b = grid->bounds();
  EXPECT_DOUBLE_EQ(b.northDegrees, 90.0);
  EXPECT_DOUBLE_EQ(b.southDegrees, -90.0);
  EXPECT_DOUBLE_EQ(b.westDegrees, 0.0);
  EXPECT_DOUBLE_EQ(b.eastDegrees, 360.0);
  EXPECT_DOUBLE_EQ(grid->geometry().latSpacingDegrees, 0.25);
  EXPECT_TRUE(grid->wrapsLongitude());
  EXPECT_TRUE(grid->coversPoles());

  const GridStats stats = grid->computeStats();
  EXPECT_EQ(stats.maxMeters, 21134.0);  // Olympus Mons
  EXPECT_DOUBLE_EQ(stats.maxLatDegrees, 17.375);
  EXPECT_DOUBLE_EQ(stats.maxLonDegrees, 226.875);
  EXPECT_EQ(stats.minMeters, -8068.0);  // Hellas
  EXPECT_DOUBLE_EQ(stats.minLatDegrees, -32.875);
  EXPECT_DOUBLE_EQ(stats.minLonDegrees, 62.125);
  EXPECT_NEAR(stats.meanMeters, -722.0, 5.0);
  EXPECT_EQ(stats.noDataCount, 0);
  // Sampling at the bin centre returns the bin; Olympus Mons by east and by west longitude.
  EXPECT_DOUBLE_EQ(*grid->sampleBilinear(17.375, 226.875), 21134.0);
  EXPECT_DOUBLE_EQ(*grid->sampleBilinear(17.375, 226.875 - 360.0), 21134.0);
  // Arsia Mons (about 8.3°S 239.9°E): its summit region stands above 16 km.
  double arsia = -1e9;
  for (double lat = -10.0; lat <= -7.0; lat += 0.25) {
    for (double lon = 238.0; lon <= 242.0; lon += 0.25) {
      arsia = std::max(arsia, *grid->sampleBilinear(lat, lon));
    }
  }
  EXPECT_GT(arsia, 16000.0);
}

TEST(DemReader, MolaImageNamedAloneIsReadThroughTheLabelBesideIt) {
  PBDAM_REQUIRE_DATA(label, test::dataDir() / kMolaLabel);
  PBDAM_REQUIRE_DATA(image, test::dataDir() / kMolaImage);
  auto throughLabel = readDem(label);
  ASSERT_TRUE(throughLabel) << throughLabel.error().message;
  EXPECT_TRUE(throughLabel->source().labelPath.empty());
  EXPECT_FALSE(pdsLabelFor(label));  // GDAL reads a label as it is

  ASSERT_EQ(pdsLabelFor(image), label);
  auto grid = readDem(image);
  ASSERT_TRUE(grid) << grid.error().message;
  EXPECT_EQ(grid->source().path, image.string());
  EXPECT_EQ(grid->source().labelPath, label.string());
  EXPECT_EQ(grid->source().body, "mars");
  EXPECT_EQ(grid->geometry().width, throughLabel->geometry().width);
  EXPECT_DOUBLE_EQ(grid->bounds().westDegrees, throughLabel->bounds().westDegrees);
  const auto a = throughLabel->heightsMeters();
  const auto b = grid->heightsMeters();
  ASSERT_EQ(a.size(), b.size());
  EXPECT_TRUE(std::equal(a.begin(), a.end(), b.begin()));

  // An upper-case label beside a lower-case image, as PDS archives ship them.
  test::TempDir dir;
  copyMola(dir.path(), -1);
  fs::rename(dir / "megt90n000cb.lbl", dir / "megt90n000cb.LBL");
  ASSERT_EQ(pdsLabelFor(dir / "megt90n000cb.img"), dir / "megt90n000cb.LBL");
  EXPECT_TRUE(readDem(dir / "megt90n000cb.img"));

  // The label's size checks still hold when the image is named.
  test::TempDir cut;
  copyMola(cut.path(), 1000);
  expectRejected(readDem(cut / "megt90n000cb.img"), cut / "megt90n000cb.lbl", "truncated");
}

TEST(DemReader, ImageBesideALabelOfAnotherFileSaysWhichFileToPass) {
  PBDAM_REQUIRE_DATA(label, test::dataDir() / kMolaLabel);
  test::TempDir dir;
  copyMola(dir.path(), -1);
  fs::rename(dir / "megt90n000cb.img", dir / "megt90n000cb-copy.img");
  writeBytes(dir / "megt90n000cb-copy.lbl", test::readFile(dir / "megt90n000cb.lbl"));
  EXPECT_FALSE(pdsLabelFor(dir / "megt90n000cb-copy.img"));
  expectRejected(readDem(dir / "megt90n000cb-copy.img"), dir / "megt90n000cb-copy.img",
                 "does not name it: pass the PDS label that describes this image");
}

TEST(DemReader, ALargeGridMappedFromAScratchFileHoldsTheSameHeights) {
  PBDAM_REQUIRE_DATA(label, test::dataDir() / kMolaLabel);
  auto inMemory = readDem(label);
  ASSERT_TRUE(inMemory) << inMemory.error().message;
  EXPECT_FALSE(inMemory->fileBacked());

  test::TempDir dir;
  DemReadOptions mapped;
  mapped.scratchDirectory = dir.path();
  mapped.mapAtBytes = 0;  // MOLA's 4 MB counts as large here
  auto grid = readDem(label, mapped);
  ASSERT_TRUE(grid) << grid.error().message;
  EXPECT_TRUE(grid->fileBacked());
  // The scratch file has no name: nothing is left in the directory.
  EXPECT_TRUE(fs::is_empty(dir.path()));
  const auto a = inMemory->heightsMeters();
  const auto b = grid->heightsMeters();
  ASSERT_EQ(a.size(), b.size());
  EXPECT_TRUE(std::equal(a.begin(), a.end(), b.begin()));
  // Dropping the pages from the process keeps the heights (they come back from the file).
  grid->releaseResident();
  EXPECT_TRUE(std::equal(a.begin(), a.end(), b.begin()));
  EXPECT_DOUBLE_EQ(*grid->sampleBicubic(17.375, 226.875),
                   *inMemory->sampleBicubic(17.375, 226.875));
  // Copies share the mapping and keep it alive.
  const HeightGrid copy = *grid;
  grid = readDem(label);
  EXPECT_EQ(copy.at(0, 0), inMemory->at(0, 0));
  EXPECT_EQ(copy.at(719, 1439), inMemory->at(719, 1439));

  // Where no scratch file can be made, the grid is read into memory.
  mapped.scratchDirectory = dir / "missing";
  auto fallback = readDem(label, mapped);
  ASSERT_TRUE(fallback) << fallback.error().message;
  EXPECT_FALSE(fallback->fileBacked());
  EXPECT_EQ(fallback->at(100, 100), inMemory->at(100, 100));
}

TEST(DemReader, MolaRadiusAsRawGridGivesThePlausibleAreoid) {
  PBDAM_REQUIRE_DATA(label, test::dataDir() / kMolaLabel);
  PBDAM_REQUIRE_DATA(radiusPath, test::dataDir() / kMolaRadius);
  auto layout = parseRawType("int16be");
  ASSERT_TRUE(layout);
  ASSERT_TRUE(parseRawSize("1440,720", *layout));
  ASSERT_TRUE(parseRawBounds("-90,0,90,360", *layout));
  DemReadOptions options;
  options.raw = *layout;
  auto radius = readDem(radiusPath, options);
  ASSERT_TRUE(radius) << radius.error().message;
  auto topo = readDem(label);
  ASSERT_TRUE(topo);
  EXPECT_EQ(radius->bounds().northDegrees, 90.0);
  // Areoid = radius − 3,396,000 − topography: about −18.3 km (poles) to +2.3 km.
  double lo = 1e9;
  double hi = -1e9;
  for (std::size_t k = 0; k < topo->heightsMeters().size(); ++k) {
    const double areoid = static_cast<double>(radius->heightsMeters()[k]) -
                          static_cast<double>(topo->heightsMeters()[k]);
    lo = std::min(lo, areoid);
    hi = std::max(hi, areoid);
  }
  EXPECT_NEAR(lo, -18300.0, 300.0);
  EXPECT_NEAR(hi, 2300.0, 300.0);
}

TEST(DemReader, Etopo5IsTheWholeEarthWithItsKnownExtremes) {
  PBDAM_REQUIRE_DATA(path, PBDAM_ETOPO5_PATH);
  auto grid = readDem(path);
  ASSERT_TRUE(grid) << grid.error().message;
  EXPECT_EQ(grid->width(), 4320);
  EXPECT_EQ(grid->height(), 2161);
  EXPECT_FALSE(grid->geometry().pixelIsArea);  // rows at −90 and +90 are pole samples
  EXPECT_DOUBLE_EQ(grid->geometry().lonSpacingDegrees, 1.0 / 12.0);
  EXPECT_DOUBLE_EQ(grid->geometry().firstLatDegrees, 90.0);
  EXPECT_DOUBLE_EQ(grid->geometry().firstLonDegrees, 0.0);
  EXPECT_TRUE(grid->wrapsLongitude());
  EXPECT_TRUE(grid->coversPoles());
  const GridStats stats = grid->computeStats();
  EXPECT_EQ(stats.minMeters, -10376.0);  // Mariana Trench
  EXPECT_NEAR(stats.minLatDegrees, 11.33, 0.01);
  EXPECT_NEAR(stats.minLonDegrees, 142.33, 0.01);
  EXPECT_EQ(stats.maxMeters, 7833.0);
  EXPECT_NEAR(stats.maxLatDegrees, 36.33, 0.01);
  EXPECT_NEAR(stats.maxLonDegrees, 75.08, 0.01);
  // Mid-Pacific abyssal plain.
  EXPECT_LT(*grid->sampleBilinear(10.0, -160.0), -3500.0);
  // A seam-crossing sample on row 960 (10°N): 359.95°E lies 0.4 of the way from column 4319
  // (359.9167°E) to column 0 (360°E).
  const double expected =
      0.6 * static_cast<double>(grid->at(960, 4319)) + 0.4 * static_cast<double>(grid->at(960, 0));
  EXPECT_NEAR(*grid->sampleBilinear(10.0, 359.95), expected, 1e-9);
  EXPECT_NEAR(*grid->sampleBilinear(10.0, -0.05), expected, 1e-9);
  EXPECT_NE(grid->at(960, 4319), grid->at(960, 0));
}

TEST(DemReader, GeoTiffKeepsItsGeoreference) {
  PBDAM_REQUIRE_DATA(path, test::dataDir() / "geotiff/terra_elev_luxembourg.tif");
  auto grid = readDem(path);
  ASSERT_TRUE(grid) << grid.error().message;
  EXPECT_EQ(grid->width(), 95);
  EXPECT_EQ(grid->height(), 90);
  EXPECT_EQ(grid->source().body, "earth");
  const LatLonBounds b = grid->bounds();
  EXPECT_NEAR(b.westDegrees, 5.7417, 1e-3);
  EXPECT_NEAR(b.eastDegrees, 6.5333, 1e-3);
  EXPECT_NEAR(b.southDegrees, 49.4417, 1e-3);
  EXPECT_NEAR(b.northDegrees, 50.1917, 1e-3);
  const GridStats stats = grid->computeStats();
  EXPECT_EQ(stats.minMeters, 141.0);
  EXPECT_EQ(stats.maxMeters, 547.0);
  EXPECT_GT(stats.noDataCount, 0);  // outside the country's border
}

/// Writes a 1201×1201 SRTM-3 tile N45E006.hgt with value 1000 + row − col, voids at (r, r).
fs::path writeSrtmTile(const fs::path& dir) {
  const int n = 1201;
  std::string bytes(static_cast<std::size_t>(n * n * 2), '\0');
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c) {
      int v = 1000 + r - c;
      if (r == c && r % 100 == 50) v = -32768;
      const auto u = static_cast<std::uint16_t>(static_cast<std::int16_t>(v));
      const std::size_t k = 2 * (static_cast<std::size_t>(r) * static_cast<std::size_t>(n) +
                                 static_cast<std::size_t>(c));
      bytes[k] = static_cast<char>(u >> 8);
      bytes[k + 1] = static_cast<char>(u & 0xff);
    }
  }
  writeBytes(dir / "N45E006.hgt", bytes);
  return dir / "N45E006.hgt";
}

TEST(DemReader, SrtmTileHasItsSizeVoidsAndCorners) {
  test::TempDir dir;
  const fs::path tile = writeSrtmTile(dir.path());
  auto grid = readDem(tile);
  ASSERT_TRUE(grid) << grid.error().message;
  EXPECT_EQ(grid->width(), 1201);
  EXPECT_EQ(grid->height(), 1201);
  EXPECT_FALSE(grid->geometry().pixelIsArea);
  EXPECT_EQ(grid->source().body, "earth");
  const LatLonBounds b = grid->bounds();
  EXPECT_NEAR(b.southDegrees, 45.0, 1e-9);
  EXPECT_NEAR(b.northDegrees, 46.0, 1e-9);
  EXPECT_NEAR(b.westDegrees, 6.0, 1e-9);
  EXPECT_NEAR(b.eastDegrees, 7.0, 1e-9);
  EXPECT_EQ(grid->computeStats().noDataCount, 12);
  EXPECT_DOUBLE_EQ(*grid->sampleBilinear(46.0, 6.0), 1000.0);           // NW corner
  EXPECT_DOUBLE_EQ(*grid->sampleBilinear(46.0, 7.0), 1000.0 - 1200.0);  // NE corner
  EXPECT_DOUBLE_EQ(*grid->sampleBilinear(45.0, 6.0), 1000.0 + 1200.0);  // SW corner
  EXPECT_DOUBLE_EQ(*grid->sampleBilinear(45.0, 7.0), 1000.0);           // SE corner
  EXPECT_TRUE(std::isnan(grid->at(50, 50)));
  // Next to a void, the remaining neighbours carry the sample.
  EXPECT_TRUE(
      grid->sampleBilinear(grid->latOfRowDegrees(50), grid->lonOfColumnDegrees(50) + 0.0001));
}

TEST(DemReader, ProjectedUtmGeoTiffIsWarpedToItsLatLonBounds) {
  test::TempDir dir;
  const fs::path path = dir / "utm32.tif";
  // 200 km × 150 km on the rotated UTM 32N grid of Utm32GeoTiff.h.
  const int w = 200;
  const int h = 150;
  ASSERT_TRUE(
      test::writeUtm32GeoTiff(path, w, h, GDT_Int16,
                              std::vector<std::vector<std::int16_t>>{std::vector<std::int16_t>(
                                  static_cast<std::size_t>(w * h), 700)}));

  // The expected footprint: the UTM inverse of points along the grid's outline.
  const auto& gt = test::kUtm32Transform;
  LatLonBounds expected{90.0, 360.0, -90.0, -360.0};
  for (int k = 0; k <= 400; ++k) {
    const double t = k / 400.0;
    double xs[4] = {gt[0] + t * w * gt[1], gt[0] + t * w * gt[1], gt[0], gt[0] + w * gt[1]};
    double ys[4] = {gt[3], gt[3] + h * gt[5], gt[3] + t * h * gt[5], gt[3] + t * h * gt[5]};
    ASSERT_TRUE(test::utm32ToLonLat(xs, ys, 4));
    for (int e = 0; e < 4; ++e) {
      expected.westDegrees = std::min(expected.westDegrees, xs[e]);
      expected.eastDegrees = std::max(expected.eastDegrees, xs[e]);
      expected.southDegrees = std::min(expected.southDegrees, ys[e]);
      expected.northDegrees = std::max(expected.northDegrees, ys[e]);
    }
  }

  auto grid = readDem(path);
  ASSERT_TRUE(grid) << grid.error().message;
  EXPECT_TRUE(grid->source().warped);
  EXPECT_EQ(grid->source().body, "earth");
  const LatLonBounds b = grid->bounds();
  const double cellLat = grid->geometry().latSpacingDegrees;
  const double cellLon = grid->geometry().lonSpacingDegrees;
  EXPECT_NEAR(b.westDegrees, expected.westDegrees, cellLon);
  EXPECT_NEAR(b.eastDegrees, expected.eastDegrees, cellLon);
  EXPECT_NEAR(b.southDegrees, expected.southDegrees, cellLat);
  EXPECT_NEAR(b.northDegrees, expected.northDegrees, cellLat);
  // Native resolution: about 1 km cells (0.009° of latitude).
  EXPECT_NEAR(cellLat, 1000.0 / 111200.0, 0.003);
  EXPECT_NEAR(*grid->sampleBilinear(0.5 * (b.southDegrees + b.northDegrees),
                                    0.5 * (b.westDegrees + b.eastDegrees)),
              700.0, 1e-3);
  // Outside the source footprint (the corners of the lat/lon box) the grid holds nodata.
  const GridStats stats = grid->computeStats();
  EXPECT_EQ(stats.minMeters, 700.0);
  EXPECT_EQ(stats.maxMeters, 700.0);
  EXPECT_GT(stats.noDataCount, 0);
}

TEST(DemReader, RejectsTruncatedMolaImage) {
  PBDAM_REQUIRE_DATA(label, test::dataDir() / kMolaLabel);
  test::TempDir dir;
  const fs::path copy = copyMola(dir.path(), 1000000);
  expectRejected(readDem(copy), copy, "truncated");
}

TEST(DemReader, RejectsLabelDataSizeMismatch) {
  PBDAM_REQUIRE_DATA(label, test::dataDir() / kMolaLabel);
  test::TempDir dir;
  const fs::path copy = copyMola(dir.path(), -1, [](const std::string& l) {
    return replaceOnce(l, "LINES                        = 720",
                       "LINES                        = 700");
  });
  expectRejected(readDem(copy), copy, "mismatch");
}

TEST(DemReader, RejectsProjectionOffsetsBeyondThePole) {
  PBDAM_REQUIRE_DATA(label, test::dataDir() / kMolaLabel);
  test::TempDir dir;
  const fs::path copy = copyMola(dir.path(), -1, [](const std::string& l) {
    return replaceOnce(l, "LINE_PROJECTION_OFFSET       = 360.5",
                       "LINE_PROJECTION_OFFSET       = 370.5");
  });
  expectRejected(readDem(copy), copy, "beyond a pole");
}

TEST(DemReader, RejectsGarbledLabel) {
  PBDAM_REQUIRE_DATA(label, test::dataDir() / kMolaLabel);
  test::TempDir dir;
  const fs::path copy = copyMola(dir.path(), -1, [](std::string l) {
    for (std::size_t k = 0; k < l.size(); k += 7) l[k] = '\x01';
    return l;
  });
  expectRejected(readDem(copy), copy, "");
}

TEST(DemReader, RejectsTruncatedNetcdf) {
  PBDAM_REQUIRE_DATA(path, PBDAM_ETOPO5_PATH);
  test::TempDir dir;
  const fs::path copy = dir / "etopo5.cdf";
  std::string bytes = test::readFile(path);
  bytes.resize(3000000);
  writeBytes(copy, bytes);
  expectRejected(readDem(copy), copy, "truncated");
  bytes.resize(100);  // header cut short
  writeBytes(copy, bytes);
  expectRejected(readDem(copy), copy, "");
}

TEST(DemReader, RejectsTruncatedGeoTiff) {
  PBDAM_REQUIRE_DATA(path, test::dataDir() / "geotiff/terra_elev_luxembourg.tif");
  test::TempDir dir;
  const fs::path copy = dir / "cut.tif";
  std::string bytes = test::readFile(path);
  bytes.resize(4000);
  writeBytes(copy, bytes);
  expectRejected(readDem(copy), copy, "cannot read");
}

TEST(DemReader, RejectsTruncatedSrtmTile) {
  test::TempDir dir;
  const fs::path tile = writeSrtmTile(dir.path());
  std::string bytes = test::readFile(tile);
  bytes.resize(bytes.size() - 5000);
  writeBytes(tile, bytes);
  expectRejected(readDem(tile), tile, "");
}

TEST(DemReader, RejectsMissingUnknownAndMisdescribedFiles) {
  test::TempDir dir;
  expectRejected(readDem(dir / "nope.tif"), dir / "nope.tif", "no such file");
  writeBytes(dir / "notes.txt", "this is not a raster\n");
  expectRejected(readDem(dir / "notes.txt"), dir / "notes.txt", "not a raster format");
  writeBytes(dir / "grid.raw", std::string(100, '\0'));
  auto layout = parseRawType("float32le");
  ASSERT_TRUE(layout);
  ASSERT_TRUE(parseRawSize("5,6", *layout));
  ASSERT_TRUE(parseRawBounds("0,0,6,5", *layout));
  DemReadOptions options;
  options.raw = *layout;
  expectRejected(readDem(dir / "grid.raw", options), dir / "grid.raw", "raw size mismatch");
  ASSERT_TRUE(parseRawSize("5,5", *layout));
  options.raw = *layout;
  EXPECT_TRUE(readDem(dir / "grid.raw", options));
}

TEST(DemReader, RawOptionParsingRejectsNonsense) {
  EXPECT_FALSE(parseRawType("int17"));
  RawLayout layout;
  EXPECT_FALSE(parseRawSize("0,5", layout));
  EXPECT_FALSE(parseRawSize("1.5,5", layout));
  EXPECT_FALSE(parseRawSize("5", layout));
  EXPECT_FALSE(parseRawBounds("10,0,5,10", layout));   // S > N
  EXPECT_FALSE(parseRawBounds("-91,0,5,10", layout));  // beyond the pole
  EXPECT_FALSE(parseRawBounds("0,10,5,0", layout));    // W > E
  EXPECT_FALSE(parseRawBounds("0,0,5,400", layout));   // more than a turn
  EXPECT_TRUE(parseRawBounds("-90,-180,90,180", layout));
}

TEST(DemReader, ACompoundCrsNamesTheVerticalDatum) {
  test::TempDir dir;
  GDALAllRegister();
  GDALDriverH gtiff = GDALGetDriverByName("GTiff");
  ASSERT_NE(gtiff, nullptr);
  const auto write = [&](const fs::path& path, const char* crsText) {
    GDALDatasetH ds = GDALCreate(gtiff, path.c_str(), 20, 10, 1, GDT_Int16, nullptr);
    ASSERT_NE(ds, nullptr);
    double gt[6] = {6.0, 0.01, 0.0, 50.0, 0.0, -0.01};
    GDALSetGeoTransform(ds, gt);
    OGRSpatialReferenceH crs = OSRNewSpatialReference(nullptr);
    ASSERT_EQ(OSRSetFromUserInput(crs, crsText), OGRERR_NONE);
    GDALSetSpatialRef(ds, crs);
    std::vector<std::int16_t> values(200, 300);
    ASSERT_EQ(GDALRasterIO(GDALGetRasterBand(ds, 1), GF_Write, 0, 0, 20, 10, values.data(), 20, 10,
                           GDT_Int16, 0, 0),
              CE_None);
    OSRDestroySpatialReference(crs);
    GDALClose(ds);
  };
  write(dir / "egm96.tif", "EPSG:4326+5773");  // WGS 84 + EGM96 height
  write(dir / "plain.tif", "EPSG:4326");
  auto withDatum = readDem(dir / "egm96.tif");
  ASSERT_TRUE(withDatum.ok()) << withDatum.error().message;
  EXPECT_EQ(withDatum->source().verticalDatum, "EGM96 height");
  EXPECT_EQ(withDatum->source().body, "earth");
  auto without = readDem(dir / "plain.tif");
  ASSERT_TRUE(without.ok()) << without.error().message;
  EXPECT_EQ(without->source().verticalDatum, "");
}

}  // namespace
}  // namespace pbdam::formats
