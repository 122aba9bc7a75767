// The `pbdam` command line as a user runs it: --help everywhere, --version, `dem info` output
// in text and JSON on real data, DEM inputs (an image beside its label, raw grids) for dem info,
// build and verify, and bad input → one clear line on stderr and exit code 2.
#include <gdal_priv.h>
#include <gtest/gtest.h>
#include <ogr_spatialref.h>
#include <sys/wait.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "TestData.h"

namespace pbdam::tools {
namespace {

using CliRun = test::CommandRun;

/// The comma-separated cells of one CSV line (frames.csv has no quoted cells).
std::vector<std::string> splitCsv(const std::string& line) {
  std::vector<std::string> cells;
  std::istringstream row(line);
  for (std::string cell; std::getline(row, cell, ',');) cells.push_back(cell);
  return cells;
}

/// Runs pbdam with `args` (a shell-quoted string), capturing stdout and stderr.
CliRun runPbdam(const std::string& args) {
  return test::runCommand(std::string("'") + PBDAM_EXE + "' " + args);
}

// OpenImageIO (about 260 libraries) is loaded only by processes that read or write an image,
// from the module beside pbdam: pbdam itself does not link it, the module does.
TEST(Cli, OpenImageIoIsAModuleBesidePbdam) {
  const test::CommandRun needed =
      test::runCommand("readelf -d " + std::string(PBDAM_EXE) + " | grep NEEDED");
  ASSERT_EQ(needed.exitCode, 0) << needed.err;
  EXPECT_EQ(needed.out.find("OpenImageIO"), std::string::npos) << needed.out;
  const std::filesystem::path module =
      std::filesystem::path(PBDAM_EXE).parent_path() / "libpbdam_oiio.so";
  ASSERT_TRUE(std::filesystem::is_regular_file(module)) << module;
  const test::CommandRun modules = test::runCommand("readelf -d " + module.string());
  EXPECT_NE(modules.out.find("libOpenImageIO"), std::string::npos) << modules.out;
}

TEST(Cli, HelpAndVersion) {
  for (const char* args :
       {"--help", "dem --help", "dem info --help", "devices --help", "build --help", "info --help",
        "verify --help", "height --help", "path --help", "path great-circle --help",
        "path waypoints --help", "bench --help"}) {
    const CliRun run = runPbdam(args);
    EXPECT_EQ(run.exitCode, 0) << args << "\n" << run.err;
    EXPECT_NE(run.out.find("Usage"), std::string::npos) << args << "\n" << run.out;
  }
  const CliRun version = runPbdam("--version");
  EXPECT_EQ(version.exitCode, 0);
  EXPECT_NE(version.out.find("pbdam 0."), std::string::npos) << version.out;
  EXPECT_NE(runPbdam("").exitCode, 0);  // a subcommand is required
}

TEST(Cli, BuildInfoVerifyOnMola) {
#if defined(__SANITIZE_THREAD__)
  // build and verify run TBB-parallel code, and Debian's libtbb is not instrumented: TSan would
  // report TBB's own task handoffs (docs/decisions.md). Covered by the release and asan runs.
  GTEST_SKIP() << "TBB-parallel commands are not checked under ThreadSanitizer";
#endif
  PBDAM_REQUIRE_DATA(dem, test::dataDir() / "mars/megt90n000cb.lbl");
  test::TempDir dir;
  const std::string out = (dir / "mars").string();
  const CliRun build = runPbdam("build --dem '" + dem.string() + "' --planet mars --out '" + out +
                                "' --levels 2 --leaf-vertices 17 --texture-tile 32 --quiet");
  ASSERT_EQ(build.exitCode, 0) << build.err;
  EXPECT_NE(build.out.find("built "), std::string::npos) << build.out;
  const CliRun info = runPbdam("info '" + out + "' --json");
  ASSERT_EQ(info.exitCode, 0) << info.err;
  const auto j = nlohmann::json::parse(info.out);
  EXPECT_EQ(j["planet"], "mars");
  EXPECT_EQ(j["depth"], 2);
  EXPECT_EQ(j["patches"], 12 * 7);
  EXPECT_LT(j["compression_ratio"].get<double>(), 0.6);
  // A BC5 normal map beside each BC1 tile: 16² texels, a quarter of the tile's area at twice
  // BC1's bytes per block, so about half its bytes (LZO decides per tile).
  EXPECT_EQ(j["texture_normal_format"], "bc5");
  const double normals = j["bytes"]["normal_maps"].get<double>();
  EXPECT_GT(normals, 0.2 * j["bytes"]["textures"].get<double>());
  EXPECT_LT(normals, 0.8 * j["bytes"]["textures"].get<double>());
  const CliRun verify = runPbdam("verify '" + out + "' --dem '" + dem.string() + "' --json");
  ASSERT_EQ(verify.exitCode, 0) << verify.err << verify.out;
  EXPECT_TRUE(nlohmann::json::parse(verify.out)["ok"].get<bool>());
  // Damage one byte of a face file: verify exits 2 and names the file.
  const std::string face = out + "/face1.pbdam";
  {
    std::fstream f(face, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(300);
    f.put('\x7f');
  }
  const CliRun bad = runPbdam("verify '" + out + "' --quiet");
  EXPECT_EQ(bad.exitCode, 2);
  EXPECT_NE(bad.err.find("face1.pbdam"), std::string::npos) << bad.err;
}

TEST(Cli, DevicesListsLavapipeAsDefault) {
  const CliRun run = runPbdam("devices --json");
  ASSERT_EQ(run.exitCode, 0) << run.err;
  const auto j = nlohmann::json::parse(run.out);
  ASSERT_TRUE(j.is_array());
  int defaults = 0;
  for (const auto& d : j) {
    if (d["default"].get<bool>()) {
      ++defaults;
      EXPECT_EQ(d["driver"], "llvmpipe");
      EXPECT_EQ(d["type"], "cpu");
    }
  }
  EXPECT_EQ(defaults, 1) << run.out;
}

TEST(Cli, DemInfoJsonOnMola) {
  PBDAM_REQUIRE_DATA(label, test::dataDir() / "mars/megt90n000cb.lbl");
  const CliRun run = runPbdam("dem info '" + label.string() + "' --at 17.375,-133.125 --json");
  ASSERT_EQ(run.exitCode, 0) << run.err;
  const auto j = nlohmann::json::parse(run.out);
  EXPECT_EQ(j["width"], 1440);
  EXPECT_EQ(j["height"], 720);
  EXPECT_EQ(j["body"], "mars");
  EXPECT_EQ(j["format"].get<std::string>().rfind("PDS", 0), 0u);
  EXPECT_EQ(j["max"]["height_m"], 21134.0);
  EXPECT_EQ(j["max"]["lat_deg"], 17.375);
  EXPECT_EQ(j["max"]["lon_deg"], 226.875);
  EXPECT_EQ(j["min"]["height_m"], -8068.0);
  EXPECT_EQ(j["bounds_deg"]["north"], 90.0);
  EXPECT_EQ(j["bounds_deg"]["west"], 0.0);
  EXPECT_EQ(j["at"]["bilinear_m"], 21134.0);  // −133.125°E is 226.875°E
  EXPECT_EQ(j["nodata_count"], 0);
}

TEST(Cli, DemInfoTextOnEtopo5) {
  PBDAM_REQUIRE_DATA(path, PBDAM_ETOPO5_PATH);
  const CliRun run = runPbdam("dem info '" + path.string() + "' --at 27.988,86.925");
  ASSERT_EQ(run.exitCode, 0) << run.err;
  EXPECT_NE(run.out.find("4320 x 2161"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("min:      -10376.0 m at 11.3333°N 142.3333°E"), std::string::npos)
      << run.out;
  EXPECT_NE(run.out.find("max:      7833.0 m"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("bilinear"), std::string::npos);
}

void expectBadInput(const std::string& args, const std::string& mention) {
  const CliRun run = runPbdam(args);
  EXPECT_EQ(run.exitCode, 2) << args << "\nstdout: " << run.out << "\nstderr: " << run.err;
  EXPECT_NE(run.err.find(mention), std::string::npos) << args << "\nstderr: " << run.err;
  EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
}

TEST(Cli, BadInputGivesOneLineAndExitCode2) {
  test::TempDir dir;
  std::ofstream(dir / "junk.tif") << "not a raster";
  std::ofstream(dir / "short.cdf") << "CDF\x01";
  expectBadInput("dem info '" + (dir / "missing.lbl").string() + "'", "missing.lbl: no such file");
  expectBadInput("dem info '" + (dir / "junk.tif").string() + "'", "junk.tif");
  expectBadInput("dem info '" + (dir / "short.cdf").string() + "'", "short.cdf");
  expectBadInput("dem info x --at 95,0", "--at '95,0'");
  expectBadInput("dem info x --at 10", "--at '10'");
  expectBadInput("dem info x --raw-size 10,10", "needs all of");
  expectBadInput("dem info x --raw-size 10,10 --raw-type int17 --bounds 0,0,1,1", "int17");
  expectBadInput("dem info x --bogus", "--bogus");
  expectBadInput("dem info", "FILE is required");
  expectBadInput("dem info x --raw-header -5", "raw-header");
  expectBadInput("build --planet mars --out x", "--dem");
  expectBadInput("build --dem '" + (dir / "missing.lbl").string() + "' --planet mars --out '" +
                     (dir / "out").string() + "'",
                 "missing.lbl");
  expectBadInput("build --dem x --planet mars --out y --levels seven", "--levels 'seven'");
  expectBadInput("build --dem x --planet mars --out y --texture-format png", "png");
  expectBadInput("build --dem x --planet mars --out y --deep-region 10,60,20@8",
                 "--deep-region '10,60,20@8'");
  expectBadInput("build --dem x --planet mars --out y --deep-region 20,60,10,75@8",
                 "--deep-region '20,60,10,75@8'");
  expectBadInput("build --dem x --planet mars --out y --deep-region 10,60,20,75@x",
                 "--deep-region '10,60,20,75@x'");
  expectBadInput("info '" + (dir / "nothing").string() + "'", "no manifest");
  expectBadInput("verify '" + (dir / "nothing").string() + "'", "no manifest");
  expectBadInput("height '" + (dir / "nothing").string() + "' --at 0,0", "nothing");
  expectBadInput("height x --at 91,0", "--at");
  expectBadInput("height x --at 1,2,3", "--at '1,2,3'");
  expectBadInput("height x", "--at is required");
  const std::string csv = (dir / "p.csv").string();
  expectBadInput("path great-circle --from 0,0,1e6 --to 1,1,1e3 --duration 2 --out " + csv,
                 "needs a planet");
  expectBadInput(
      "path great-circle --from 0,0 --to 1,1,1e3 --duration 2 --planet mars --out " + csv,
      "--from '0,0'");
  expectBadInput(
      "path great-circle --from 0,0,1e6 --to 1,1,1e3 --duration 0 --planet mars --out " + csv,
      "duration");
  expectBadInput("path waypoints --via 0,0,1e6 --duration 2 --planet mars --out " + csv,
                 "two waypoints");
  expectBadInput("bench x --path " + csv + " --out y --prefetch maybe", "--prefetch 'maybe'");
  expectBadInput("bench x --path " + csv + " --out y --mode fast", "--mode 'fast'");
  expectBadInput("bench x --path " + csv + " --out y --selection tpu", "--selection 'tpu'");
  expectBadInput("bench x --path " + csv + " --out y --draws sideways", "--draws 'sideways'");
  expectBadInput("bench x --path " + csv + " --out y --readback maybe", "--readback 'maybe'");
  expectBadInput("bench x --path " + csv + " --out y --frames-in-flight 0",
                 "--frames-in-flight must be in 1..8");
  expectBadInput("bench x --path " + csv + " --out y --frames-in-flight 9",
                 "--frames-in-flight must be in 1..8");
  expectBadInput("bench x --path " + csv + " --out y --draws indirect",
                 "--draws indirect needs --selection gpu");
  expectBadInput("bench x --path '" + (dir / "none.csv").string() + "' --out y", "none.csv");
  expectBadInput(
      "build --dem x --planet earth --out y --inset a --inset b --inset-offset 1 "
      "--inset-offset 2 --inset-offset 3",
      "3 --inset-offset values for 2 --inset files");
  expectBadInput("build --dem x --planet earth --out y --inset a --inset b --inset-texture t",
                 "1 --inset-texture values for 2 --inset files");
  expectBadInput("verify x --inset a", "pass --dem FILE too");
  PBDAM_REQUIRE_DATA(tif, test::dataDir() / "geotiff/terra_elev_luxembourg.tif");
  expectBadInput("dem info '" + tif.string() + "' --at 0,0", "outside the grid");
  // An inset on another body than --planet, and one no finer than the base.
  PBDAM_REQUIRE_DATA(etopo, PBDAM_ETOPO5_PATH);
  PBDAM_REQUIRE_DATA(mola, test::dataDir() / "mars/megt90n000cb.lbl");
  expectBadInput("build --dem '" + mola.string() + "' --planet mars --out '" +
                     (dir / "o1").string() + "' --inset '" + tif.string() + "'",
                 "the inset's CRS is on earth but --planet is mars");
  expectBadInput("build --dem '" + tif.string() + "' --planet earth --out '" +
                     (dir / "o2").string() + "' --inset '" + etopo.string() + "'",
                 "are not finer than the base's");
  expectBadInput("build --dem '" + etopo.string() + "' --planet earth --out '" +
                     (dir / "o3").string() + "' --inset '" + (dir / "junk.tif").string() + "'",
                 "junk.tif");
  // An inset without georeferencing (a plain image).
  const std::string plain = (dir / "plain.pgm").string();
  std::ofstream(plain, std::ios::binary) << "P5\n4 4\n255\n" << std::string(16, '\x40');
  expectBadInput("build --dem '" + etopo.string() + "' --planet earth --out '" +
                     (dir / "o5").string() + "' --inset '" + plain + "'",
                 "has no georeferencing");
  // Inset imagery georeferenced elsewhere (a 1° square over Norway for Luxembourg).
  const std::string far = (dir / "far.tif").string();
  ASSERT_EQ(std::system(("gdal_translate -q -a_srs EPSG:4326 -a_ullr 10 60 11 59 -ot Byte '" +
                         tif.string() + "' '" + far + "'")
                            .c_str()),
            0);
  expectBadInput("build --dem '" + etopo.string() + "' --planet earth --out '" +
                     (dir / "o4").string() + "' --inset '" + tif.string() + "' --inset-texture '" +
                     far + "'",
                 "does not overlap its inset terra_elev_luxembourg.tif");
}

/// The files of dataset `dir` other than its manifest (which names the DEM file it was built from).
std::vector<std::pair<std::string, std::string>> faceFiles(const std::filesystem::path& dir) {
  std::vector<std::pair<std::string, std::string>> files;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (entry.path().extension() != ".pbdam") continue;
    std::ifstream in(entry.path(), std::ios::binary);
    files.emplace_back(entry.path().filename().string(),
                       std::string(std::istreambuf_iterator<char>(in), {}));
  }
  std::sort(files.begin(), files.end());
  return files;
}

TEST(Cli, MolaImageNamedAloneIsReadThroughItsLabel) {
#if defined(__SANITIZE_THREAD__)
  GTEST_SKIP() << "TBB-parallel commands are not checked under ThreadSanitizer";
#endif
  PBDAM_REQUIRE_DATA(label, test::dataDir() / "mars/megt90n000cb.lbl");
  PBDAM_REQUIRE_DATA(image, test::dataDir() / "mars/megt90n000cb.img");
  const CliRun info = runPbdam("dem info '" + image.string() + "' --json");
  ASSERT_EQ(info.exitCode, 0) << info.err;
  const auto j = nlohmann::json::parse(info.out);
  EXPECT_EQ(j["file"], image.string());
  EXPECT_EQ(j["label"], label.string());
  EXPECT_EQ(j["width"], 1440);
  EXPECT_EQ(j["max"]["height_m"], 21134.0);
  EXPECT_NE(info.err.find("note: "), std::string::npos) << info.err;
  EXPECT_NE(info.err.find(label.string()), std::string::npos) << info.err;

  test::TempDir dir;
  const std::string args = " --planet mars --levels 2 --leaf-vertices 17 --texture-tile 32 --quiet";
  const CliRun fromImage = runPbdam("build --dem '" + image.string() + "' --out '" +
                                    (dir / "img").string() + "'" + args);
  ASSERT_EQ(fromImage.exitCode, 0) << fromImage.err;
  EXPECT_NE(fromImage.err.find(label.string()), std::string::npos) << fromImage.err;
  const CliRun fromLabel = runPbdam("build --dem '" + label.string() + "' --out '" +
                                    (dir / "lbl").string() + "'" + args);
  ASSERT_EQ(fromLabel.exitCode, 0) << fromLabel.err;
  EXPECT_EQ(fromLabel.err.find("note: "), std::string::npos) << fromLabel.err;
  EXPECT_EQ(faceFiles(dir / "img"), faceFiles(dir / "lbl"));
  const CliRun verify =
      runPbdam("verify '" + (dir / "img").string() + "' --dem '" + image.string() + "' --json");
  ASSERT_EQ(verify.exitCode, 0) << verify.err << verify.out;
  EXPECT_TRUE(nlohmann::json::parse(verify.out)["ok"].get<bool>());
  EXPECT_GT(nlohmann::json::parse(verify.out)["dem_samples_checked"].get<int>(), 0);
}

TEST(Cli, BuildAndVerifyTakeTheRawGridOptionsOfDemInfo) {
#if defined(__SANITIZE_THREAD__)
  GTEST_SKIP() << "TBB-parallel commands are not checked under ThreadSanitizer";
#endif
  // MOLA's radius grid has no label: 1440x720 big-endian int16 metres, the whole planet.
  PBDAM_REQUIRE_DATA(radius, test::dataDir() / "mars/megr90n000cb.img");
  const std::string raw =
      " --raw-size 1440,720 --raw-type int16be --bounds -90,0,90,360 --raw-header 0";
  const CliRun info = runPbdam("dem info '" + radius.string() + "'" + raw + " --json");
  ASSERT_EQ(info.exitCode, 0) << info.err;
  const auto j = nlohmann::json::parse(info.out);
  EXPECT_EQ(j["width"], 1440);
  // Radii minus 3,396 km: Olympus Mons stands highest, as in the topography.
  EXPECT_EQ(j["max"]["height_m"], 21241.0);
  EXPECT_EQ(j["max"]["lat_deg"], 17.375);

  test::TempDir dir;
  const std::string out = (dir / "radius").string();
  const CliRun build =
      runPbdam("build --dem '" + radius.string() + "'" + raw + " --planet sphere:3396000 --out '" +
               out + "' --levels 2 --leaf-vertices 17 --texture-tile 32 --quiet");
  ASSERT_EQ(build.exitCode, 0) << build.err;
  const CliRun verify =
      runPbdam("verify '" + out + "' --dem '" + radius.string() + "'" + raw + " --json");
  ASSERT_EQ(verify.exitCode, 0) << verify.err << verify.out;
  EXPECT_TRUE(nlohmann::json::parse(verify.out)["ok"].get<bool>());
  EXPECT_GT(nlohmann::json::parse(verify.out)["dem_samples_checked"].get<int>(), 0);

  // The same checks and messages as `dem info`.
  expectBadInput("build --dem '" + radius.string() + "' --planet mars --out '" + out +
                     "x' --raw-size 1440,720",
                 "needs all of");
  expectBadInput("build --dem '" + radius.string() + "' --planet mars --out '" + out +
                     "x' --raw-size 1440,720 --raw-type int17 --bounds -90,0,90,360",
                 "int17");
  expectBadInput("build --dem x --planet mars --out y --raw-header -5", "raw-header");
  expectBadInput("verify '" + out + "' --dem '" + radius.string() + "' --raw-size 1440,721" +
                     " --raw-type int16be --bounds -90,0,90,360",
                 "raw size mismatch");
  expectBadInput("verify '" + out + "'" + raw, "pass --dem FILE");
  expectBadInput("verify '" + out + "' --dem '" + radius.string() + "' --quiet",
                 "not a raster format");
}

// Survey tiles (the `survey` test dataset: the Luxembourg GeoTIFF cut into two tiles sharing a
// column, voids punched into both, given as two --insets): one inset surface in the manifest,
// the voids filled from their rims, and `height` saying so at a punched sample and not beside it.
TEST(Cli, SurveyTilesAreOneSurfaceAndHeightNamesTheirFilledVoids) {
  PBDAM_REQUIRE_DATASET(dir, "survey");
  const auto manifest = nlohmann::json::parse(test::readFile(dir / "manifest.json"));
  ASSERT_EQ(manifest["insets"].size(), 1u) << "two tiles, one surface";
  EXPECT_EQ(manifest["insets"][0]["file"], "west.asc + east.asc");
  EXPECT_EQ(manifest["voids"]["file"], "voids.bin");
  const auto height = [&](const std::string& at) {
    const CliRun run = runPbdam("height '" + dir.string() + "' --at " + at + " --json");
    EXPECT_EQ(run.exitCode, 0) << run.err;
    return nlohmann::json::parse(run.out);
  };
  // The punched 2 x 2 block (49.8542°N 5.9958°E its north-west sample) and the single sample.
  for (const char* at : {"49.8542,5.9958", "49.8458,6.0042", "49.7542,6.2625"}) {
    const auto j = height(at);
    ASSERT_TRUE(j["void"].is_object()) << at << ": " << j.dump();
    EXPECT_EQ(j["void"]["inset"], "west.asc + east.asc");
    EXPECT_EQ(j["void"]["filled_from"], "rim");
    // The leaf's sources name the inset (and the base too: in so small a country every leaf
    // reaches the band along its border).
    EXPECT_NE(j["sources"].dump().find("west.asc + east.asc"), std::string::npos) << at;
  }
  EXPECT_TRUE(height("49.8708,5.9958")["void"].is_null());  // two samples north: valid
  EXPECT_TRUE(height("48.85,2.35")["void"].is_null());      // Paris: the base alone
  const CliRun text = runPbdam("height '" + dir.string() + "' --at 49.8542,5.9958");
  EXPECT_NE(text.out.find("in a void of west.asc + east.asc, filled from its rim"),
            std::string::npos)
      << text.out;
}

// `pbdam dem info` of a set of tiles: one surface, its tile count and voids; a set that cannot
// be read is refused naming the file, and a build of it writes nothing.
TEST(Cli, DemInfoOfATileSetAndBadSetsRefusedNamingTheFile) {
  PBDAM_REQUIRE_DATASET(survey, "survey");
  const std::filesystem::path tiles = survey.parent_path() / "survey-tiles";
  const CliRun info = runPbdam("dem info '" + tiles.string() + "' --json");
  ASSERT_EQ(info.exitCode, 0) << info.err;
  const auto j = nlohmann::json::parse(info.out);
  EXPECT_EQ(j["tiles"], 2);
  EXPECT_EQ(j["width"], 95);
  EXPECT_EQ(j["voids"]["count"], 2);
  EXPECT_EQ(j["voids"]["samples"], 5);
  EXPECT_EQ(j["voids"]["fillable"], 2);
  test::TempDir dir;
  std::filesystem::create_directories(dir / "bad");
  std::filesystem::copy(tiles / "west.asc", dir / "bad/west.asc");
  std::filesystem::copy(tiles / "west.prj", dir / "bad/west.prj");
  std::ofstream(dir / "bad/broken.hgt") << "not a tile";
  const std::string out = (dir / "out").string();
  const CliRun bad = runPbdam(
      "build --dem /usr/share/ferret-vis/data/etopo5.cdf --planet earth "
      "--levels 6 --inset '" +
      (dir / "bad").string() + "' --out '" + out + "'");
  EXPECT_EQ(bad.exitCode, 2) << bad.err;
  EXPECT_NE(bad.err.find("bad/broken.hgt"), std::string::npos) << bad.err;
  EXPECT_FALSE(std::filesystem::exists(out)) << "nothing written";
  std::filesystem::create_directories(dir / "empty");
  const CliRun empty = runPbdam("dem info '" + (dir / "empty").string() + "'");
  EXPECT_EQ(empty.exitCode, 2);
  EXPECT_NE(empty.err.find("holds no tiles"), std::string::npos) << empty.err;
}

TEST(Cli, HeightOnMolaMatchesTheDemWithinTheStoredError) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const CliRun run = runPbdam("height '" + dir.string() + "' --at 17.375,226.875 --json");
  ASSERT_EQ(run.exitCode, 0) << run.err;
  const auto j = nlohmann::json::parse(run.out);
  // The MOLA summit sample is 21,134 m; the leaf's stored error bounds the difference.
  EXPECT_LE(std::abs(j["height_m"].get<double>() - 21134.0), j["error_m"].get<double>());
  EXPECT_EQ(j["planet"], "mars");
  const CliRun text = runPbdam("height '" + dir.string() + "' --at 90,0");
  EXPECT_EQ(text.exitCode, 0);
  EXPECT_NE(text.out.find("m at 90.000000, 0.000000 (mars; leaf error"), std::string::npos)
      << text.out;
}

TEST(Cli, PathThenColdBenchWithAndWithoutPrefetchOnMola) {
  PBDAM_REQUIRE_DATASET(shared, "mola");
  test::TempDir dir;
  // A private copy: cold runs evict it while other tests read the shared one.
  const std::filesystem::path dataset = dir / "mola";
  std::filesystem::copy(shared, dataset);
  const std::string path = (dir / "flight.csv").string();
  const CliRun made = runPbdam(
      "path great-circle --from 0,-60,3000e3 --to -8,-75,50e3 "
      "--duration 1 --fps 6 --dataset '" +
      dataset.string() + "' --out '" + path + "'");
  ASSERT_EQ(made.exitCode, 0) << made.err;
  EXPECT_NE(made.out.find("7 poses over 1.0 s on mars"), std::string::npos) << made.out;
  const std::string report = (dir / "report").string();
  const CliRun bench = runPbdam("bench '" + dataset.string() + "' --path '" + path + "' --out '" +
                                report + "' --cold --width 320 --height 240 --quiet");
  ASSERT_EQ(bench.exitCode, 0) << bench.err;
  EXPECT_NE(bench.out.find("prefetch off"), std::string::npos) << bench.out;
  EXPECT_NE(bench.out.find("prefetch on"), std::string::npos) << bench.out;
  std::ifstream in(dir / "report" / "summary.json");
  const auto summary = nlohmann::json::parse(in);
  ASSERT_EQ(summary["runs"].size(), 2u);
  for (const auto& run : summary["runs"]) {
    EXPECT_EQ(run["frames"], 7);
    EXPECT_LE(run["resident_after_evict_fraction"].get<double>(), 0.01);
    EXPECT_GT(run["fps_mean"].get<double>(), 0.0);
    EXPECT_GE(run["frame_ms_p99"].get<double>(), run["frame_ms_p50"].get<double>());
    EXPECT_GT(run["draw_ms_p50"].get<double>(), 0.0);
    EXPECT_LE(run["draw_ms_p50"].get<double>(), run["frame_ms_max"].get<double>());
    // Upload and draw (timestamps; CPU time on lavapipe) over the run's wall time: the device
    // works inside the frames' wall time, one submission at a time, so never more than all of it.
    EXPECT_GT(run["gpu_busy_fraction"].get<double>(), 0.0);
    EXPECT_LE(run["gpu_busy_fraction"].get<double>(), 1.0);
    // The defaults: two frames in flight, nothing read back.
    EXPECT_EQ(run["frames_in_flight"], 2);
    EXPECT_EQ(run["readback"], false);
  }
  // The defaults' light: the camera's, no atmosphere, true heights.
  EXPECT_EQ(summary["light"]["kind"], "camera");
  EXPECT_EQ(summary["light"]["atmosphere"], false);
  EXPECT_EQ(summary["light"]["normal_maps"], true);
  EXPECT_EQ(summary["exaggeration"], 1.0);
  EXPECT_TRUE(std::filesystem::file_size(dir / "report" / "report.png") > 10000);
  const std::string frames = test::readFile(dir / "report" / "frames.csv");
  EXPECT_EQ(std::count(frames.begin(), frames.end(), '\n'), 1 + 2 * 7);
  // Each run's faults are its frames' sum, and the count after the first frame leaves out
  // exactly the first frame's (rows are in run order, frame order within a run).
  std::istringstream csv(frames);
  std::string line;
  std::getline(csv, line);
  const std::vector<std::string> header = splitCsv(line);
  const auto column = static_cast<std::size_t>(
      std::find(header.begin(), header.end(), "render_thread_major_faults") - header.begin());
  ASSERT_LT(column, header.size()) << line;
  for (const auto& run : summary["runs"]) {
    std::uint64_t total = 0;
    std::uint64_t first = 0;
    for (int k = 0; k < 7 && std::getline(csv, line); ++k) {
      const std::uint64_t faults = std::stoull(splitCsv(line).at(column));
      total += faults;
      if (k == 0) first = faults;
    }
    EXPECT_EQ(run["render_thread_major_faults"].get<std::uint64_t>(), total);
    EXPECT_EQ(run["render_thread_major_faults_after_first_frame"].get<std::uint64_t>(),
              total - first);
  }
}

TEST(Cli, NoStallBenchNeverFaultsOnTheRenderThread) {
  PBDAM_REQUIRE_DATASET(shared, "mola");
  test::TempDir dir;
  // A private copy: cold runs evict it while other tests read the shared one.
  const std::filesystem::path dataset = dir / "mola";
  std::filesystem::copy(shared, dataset);
  const std::string path = (dir / "flight.csv").string();
  ASSERT_EQ(runPbdam("path waypoints --via=0,-60,3000e3 --via=-8,-75,50e3 --duration 2 --fps 5 "
                     "--planet mars --out '" +
                     path + "'")
                .exitCode,
            0);
  const CliRun bench =
      runPbdam("bench '" + dataset.string() + "' --path '" + path + "' --out '" +
               (dir / "r").string() + "' --cold --mode no-stall --width 320 --height 240 --quiet");
  ASSERT_EQ(bench.exitCode, 0) << bench.err;
  std::ifstream in(dir / "r" / "summary.json");
  const auto summary = nlohmann::json::parse(in);
  ASSERT_EQ(summary["runs"].size(), 2u);  // --prefetch both (the default): off, then on
  for (const auto& run : summary["runs"]) {
    EXPECT_EQ(run["frames"], 11);  // 2 s at 5 fps
    EXPECT_EQ(run["mode"], "no-stall");
  }
  // The dataset's pages a no-stall frame reads are resident and locked before it reads them, so
  // a render-thread major fault can only be a page of code or of a library. The process's first
  // run runs code for the first time in its first frames (decoders, the driver's paths, the
  // cache's growth: frame 1 is the first below level 1); on a loaded machine those pages can be
  // major faults (seen twice in cold CI runs under ASan, in frames 0 and 1 of the first run).
  // The second run's refinement, loader and frames are the same code with the same no-stall
  // guarantee, and the first run has run that code: there every frame is free of faults.
  EXPECT_EQ(summary["runs"][1]["render_thread_major_faults"], 0)
      << "frames.csv:\n"
      << test::readFile(dir / "r" / "frames.csv");
}

// `pbdam query cut`: a focus region alone gives a closed mesh of the whole planet (V = F/2 + 2
// for a closed triangle mesh of Euler characteristic 2) with leaves in the circle, written as a
// binary PLY of doubles; a camera's cut and a focus path too; bad selections are exit code 2.
TEST(Cli, QueryCutWritesTheFocusMeshAsPly) {
  PBDAM_REQUIRE_DATASET(dataset, "mola");
  test::TempDir dir;
  const std::string ds = "'" + dataset.string() + "'";
  const std::string ply = (dir / "focus.ply").string();
  const CliRun focus =
      runPbdam("query cut " + ds + " --focus 18.65,226.2,100e3 --out '" + ply + "' --json");
  ASSERT_EQ(focus.exitCode, 0) << focus.err;
  const auto j = nlohmann::json::parse(focus.out);
  const auto vertices = j["vertices"].get<std::uint64_t>();
  const auto triangles = j["triangles"].get<std::uint64_t>();
  EXPECT_EQ(vertices, triangles / 2 + 2) << "closed, Euler characteristic 2";
  EXPECT_EQ(j["max_level"], 8);  // the test dataset's leaves, inside the circle
  EXPECT_LE(j["min_level"].get<int>(), 2);
  // Every patch the circle reaches is a leaf.
  EXPECT_GT(j["in_focus"]["patches"].get<int>(), 0);
  EXPECT_EQ(j["in_focus"]["min_level"], 8);
  EXPECT_EQ(j["in_focus"]["leaf_level"], 8);
  const std::string bytes = test::readFile(ply);
  const std::string header = "ply\nformat binary_little_endian 1.0\n";
  EXPECT_EQ(bytes.rfind(header, 0), 0u);
  const std::size_t body = bytes.find("end_header\n") + 11;
  EXPECT_EQ(bytes.size() - body, vertices * 24 + triangles * 13);
  EXPECT_NE(bytes.find("element vertex " + std::to_string(vertices) + "\n"), std::string::npos);

  const CliRun camera = runPbdam("query cut " + ds + " --camera 18.65,226.2,600e3,0,-60,0 --out '" +
                                 (dir / "camera.ply").string() + "'");
  EXPECT_EQ(camera.exitCode, 0) << camera.err;
  EXPECT_NE(camera.out.find("wrote "), std::string::npos) << camera.out;
  {
    std::ofstream path(dir / "path.csv");
    path << "lat,lon\n0,-60\n-8,-75\n";
    std::ofstream empty(dir / "empty.csv");
    empty << "lat,lon\n";
  }
  const CliRun along =
      runPbdam("query cut " + ds + " --focus-path '" + (dir / "path.csv").string() +
               "' --focus-width-m 50e3 --out '" + (dir / "path.ply").string() + "' --json");
  ASSERT_EQ(along.exitCode, 0) << along.err;
  const auto p = nlohmann::json::parse(along.out);
  EXPECT_EQ(p["vertices"].get<std::uint64_t>(), p["triangles"].get<std::uint64_t>() / 2 + 2);

  const auto query = [&](const std::string& options) {
    std::string args = "query cut ";
    args += ds;
    args += options;
    args += " --out '";
    args += (dir / "x.ply").string();
    args += "'";
    return args;
  };
  const auto pathOption = [&](const char* file) {
    std::string option = " --focus-path '";
    option += (dir / file).string();
    option += "'";
    return option;
  };
  for (const auto& [args, mention] : std::vector<std::pair<std::string, std::string>>{
           {query(""), "give --camera, --focus or --focus-path"},
           {query(" --focus 0,0"), "--focus '0,0'"},
           {query(" --focus 0,0,-5"), "radius"},
           {query(pathOption("empty.csv")), "no points"},
           {query(pathOption("none.csv")), "cannot read"},
           {query(" --camera 0,0"), "camera"},
       }) {
    const CliRun run = runPbdam(args);
    EXPECT_EQ(run.exitCode, 2) << args;
    EXPECT_NE(run.err.find(mention), std::string::npos) << args << "\n" << run.err;
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "x.ply"));
}

// `pbdam query los`: JSON for a blocked and a clear line; bad points are exit code 2.
TEST(Cli, QueryLosAnswersInJsonAndRefusesBadPoints) {
  PBDAM_REQUIRE_DATASET(dataset, "mola");
  const std::string ds = "'" + dataset.string() + "'";
  // From 10 m above Olympus Mons' summit plateau towards the plains 200 km east: the plateau's
  // rim hides them. 20 km up over the flank, 75 km apart: clear.
  const CliRun low =
      runPbdam("query los " + ds + " --from 18.65,226.2,10 --to 18.65,230,10 --json");
  ASSERT_EQ(low.exitCode, 0) << low.err;
  const auto blocked = nlohmann::json::parse(low.out);
  EXPECT_FALSE(blocked["visible"].get<bool>());
  EXPECT_GT(blocked["blocked_at"]["distance_m"].get<double>(), 0.0);
  EXPECT_LT(blocked["blocked_at"]["distance_m"].get<double>(), blocked["distance_m"].get<double>());
  const CliRun high =
      runPbdam("query los " + ds + " --from 18.0,226.2,20000 --to 19,227,20000 --json");
  ASSERT_EQ(high.exitCode, 0) << high.err;
  EXPECT_TRUE(nlohmann::json::parse(high.out)["visible"].get<bool>());
  for (const auto& [args, mention] : std::vector<std::pair<std::string, std::string>>{
           {" --from 0,0,-1 --to 1,1,1", "underground"},
           {" --from 0,0 --to 1,1,1", "--from '0,0'"},
           {" --from 1,1,1 --to 1,1,1", "the same point"},
           {" --from 95,1,1 --to 1,1,1", "latitude"},
       }) {
    std::string command = "query los " + ds;
    command += args;
    const CliRun run = runPbdam(command);
    EXPECT_EQ(run.exitCode, 2) << args;
    EXPECT_NE(run.err.find(mention), std::string::npos) << args << "\n" << run.err;
  }
}

// `pbdam query viewshed`: a GeoTIFF mask that GDAL reads back georeferenced (the observer's
// azimuthal equidistant projection, nodata 255) with as many visible cells as the JSON says; bad
// requests are exit code 2 naming what was wrong, and write nothing.
TEST(Cli, QueryViewshedWritesAGeoreferencedMaskAndRefusesBadRequests) {
  PBDAM_REQUIRE_DATASET(dataset, "mola");
  test::TempDir dir;
  const std::string ds = "'" + dataset.string() + "'";
  const std::filesystem::path tif = dir / "olympus.tif";
  const CliRun run = runPbdam("query viewshed " + ds + " --at 18.0,226.2,3000 --radius-m 300000 " +
                              "--cell-m 5000 --out '" + tif.string() + "' --json");
  ASSERT_EQ(run.exitCode, 0) << run.err;
  const auto j = nlohmann::json::parse(run.out);
  EXPECT_EQ(j["cells"].get<int>(), 121);
  EXPECT_GT(j["visible_cells"].get<std::uint64_t>(), 0u);
  EXPECT_LT(j["visible_cells"].get<std::uint64_t>(), j["cells_in_radius"].get<std::uint64_t>());
  EXPECT_GT(j["visible_area_km2"].get<double>(), 0.0);
  EXPECT_LE(j["farthest_visible"]["distance_m"].get<double>(), 300000.0);
  GDALAllRegister();
  std::unique_ptr<GDALDataset, decltype(&GDALClose)> mask(
      GDALDataset::Open(tif.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY), &GDALClose);
  ASSERT_NE(mask, nullptr);
  EXPECT_EQ(mask->GetRasterXSize(), 121);
  EXPECT_EQ(mask->GetRasterYSize(), 121);
  std::array<double, 6> transform{};
  ASSERT_EQ(mask->GetGeoTransform(transform.data()), CE_None);
  EXPECT_DOUBLE_EQ(transform[1], 5000.0);
  EXPECT_DOUBLE_EQ(transform[0], -60.5 * 5000.0);
  const OGRSpatialReference* srs = mask->GetSpatialRef();
  ASSERT_NE(srs, nullptr);
  char* proj4 = nullptr;
  ASSERT_EQ(srs->exportToProj4(&proj4), OGRERR_NONE);
  const std::string projection(proj4);
  CPLFree(proj4);
  EXPECT_NE(projection.find("+proj=aeqd +lat_0=18 +lon_0=-133.8"), std::string::npos) << projection;
  EXPECT_NE(projection.find("+R=3396190"), std::string::npos) << projection;
  GDALRasterBand* band = mask->GetRasterBand(1);
  int hasNoData = 0;
  EXPECT_EQ(band->GetNoDataValue(&hasNoData), 255.0);
  EXPECT_TRUE(hasNoData);
  std::vector<std::uint8_t> cells(std::size_t{121} * 121);
  ASSERT_EQ(band->RasterIO(GF_Read, 0, 0, 121, 121, cells.data(), 121, 121, GDT_Byte, 0, 0),
            CE_None);
  EXPECT_EQ(static_cast<std::uint64_t>(std::count(cells.begin(), cells.end(), 1)),
            j["visible_cells"].get<std::uint64_t>());
  EXPECT_EQ(cells[0], 255) << "the corner is outside the radius";
  EXPECT_EQ(cells[60 * 121 + 60], 1) << "the observer's own cell is visible";
  for (const auto& [args, mention] : std::vector<std::pair<std::string, std::string>>{
           {" --at 0,0,-1", "underground"},
           {" --at 0,0", "--at '0,0'"},
           {" --at 95,0,10", "latitude"},
           {" --at 0,0,10 --radius-m 0", "--radius-m must be a positive"},
           {" --at 0,0,10 --radius-m -3", "--radius-m must be a positive"},
           {" --at 0,0,10 --radius-m 5e6", "beyond the horizon of the whole planet"},
           {" --at 0,0,10 --cell-m 0", "--cell-m must be a positive"},
           {" --at 0,0,10 --radius-m 5e5 --cell-m 10", "cells a side"},
       }) {
    std::string command = "query viewshed " + ds + " --out '" + (dir / "bad.tif").string() + "'";
    command += args;
    const CliRun bad = runPbdam(command);
    EXPECT_EQ(bad.exitCode, 2) << args;
    EXPECT_NE(bad.err.find(mention), std::string::npos) << args << "\n" << bad.err;
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "bad.tif"));
  const CliRun nowhere = runPbdam("query viewshed " + ds + " --at 0,0,10 --out '" +
                                  (dir / "none" / "x.tif").string() + "'");
  EXPECT_EQ(nowhere.exitCode, 2);
  EXPECT_NE(nowhere.err.find("does not exist"), std::string::npos) << nowhere.err;
}

// Cut reuse changes the decisions, not the cuts: the same triangles every frame with it on and
// off, far fewer decisions with it on; --popping measures each frame against the previous cut. The
// device's selection passes (--selection gpu) give the same cuts too.
// A benchmark says what lit it and how high it drew: summary.json names the sun's instant and
// time scale, the ambient, the atmosphere and its exposure (Mars's default), the exaggeration.
TEST(Cli, BenchSummaryNamesItsLightAndExaggeration) {
  PBDAM_REQUIRE_DATASET(dataset, "mola");
  test::TempDir dir;
  const std::string path = (dir / "flight.csv").string();
  {
    std::ofstream out(path);
    out << "t,lat,lon,alt,heading,pitch,roll\n0,-8,-75,50e3,90,-20,0\n0.5,-8,-74,50e3,90,-20,0\n";
  }
  const CliRun bench = runPbdam("bench '" + dataset.string() + "' --path '" + path + "' --out '" +
                                (dir / "r").string() +
                                "' --width 160 --height 90 --prefetch off --quiet --time "
                                "2004-01-03T16:00:00Z --time-scale 600 --exaggeration 2 "
                                "--normal-maps off");
  ASSERT_EQ(bench.exitCode, 0) << bench.err;
  std::ifstream in(dir / "r" / "summary.json");
  const auto summary = nlohmann::json::parse(in);
  EXPECT_EQ(summary["exaggeration"], 2.0);
  const auto& light = summary["light"];
  EXPECT_EQ(light["kind"], "time");
  EXPECT_EQ(light["time"], "2004-01-03T16:00:00Z");
  EXPECT_EQ(light["time_scale"], 600.0);
  EXPECT_NEAR(light["ambient"].get<double>(), 0.05, 1e-6);
  EXPECT_EQ(light["atmosphere"], true);
  EXPECT_NEAR(light["exposure"].get<double>(), 23.2, 0.1);
  EXPECT_EQ(light["normal_maps"], false);
  // Anything but on or off is refused by name.
  const CliRun bad = runPbdam("bench '" + dataset.string() + "' --path '" + path + "' --out '" +
                              (dir / "r2").string() + "' --quiet --normal-maps maybe");
  EXPECT_EQ(bad.exitCode, 2) << bad.err;
  EXPECT_NE(bad.err.find("--normal-maps 'maybe'"), std::string::npos) << bad.err;
}

TEST(Cli, BenchCutReuseKeepsTheCutsAndPoppingIsMeasured) {
  PBDAM_REQUIRE_DATASET(dataset, "mola");
  test::TempDir dir;
  const std::string path = (dir / "flight.csv").string();
  ASSERT_EQ(runPbdam("path waypoints --via=0,-60,3000e3 --via=-8,-75,50e3 --duration 2 --fps 10 "
                     "--planet mars --out '" +
                     path + "'")
                .exitCode,
            0);
  std::map<std::string, std::vector<std::string>> triangles;
  std::map<std::string, double> decisions;
  for (const std::string reuse : {"on", "off"}) {
    const std::filesystem::path out = dir / ("r-" + reuse);
    std::string command = "bench '" + dataset.string() + "' --path '" + path + "' --out '";
    command += out.string() + "' --prefetch off --cut-reuse " + reuse;
    command += " --popping --width 320 --height 240 --quiet";
    const CliRun bench = runPbdam(command);
    ASSERT_EQ(bench.exitCode, 0) << bench.err;
    EXPECT_NE(bench.out.find("popping (the previous frame's cut"), std::string::npos) << bench.out;
    std::ifstream in(out / "summary.json");
    const auto run = nlohmann::json::parse(in)["runs"][0];
    EXPECT_EQ(run["cut_reuse"], reuse == "on");
    // Popping draws each frame again right after it: one frame in flight, read back.
    EXPECT_EQ(run["frames_in_flight"], 1);
    EXPECT_EQ(run["readback"], true);
    decisions[reuse] = run["decisions_per_frame_mean"].get<double>();
    EXPECT_GE(run["popping_rms_p99"].get<double>(), 0.0);
    EXPECT_GE(run["popping_max_max"].get<double>(), run["popping_max_p50"].get<double>());
    std::istringstream csv(test::readFile(out / "frames.csv"));
    std::string line;
    std::getline(csv, line);
    EXPECT_NE(line.find(",decisions,popping_rms,popping_max,morph,morphing_patches"),
              std::string::npos)
        << line;
    EXPECT_EQ(run["morph"], "on");  // the default
    for (int frame = 0; std::getline(csv, line); ++frame) {
      const std::vector<std::string> cells = splitCsv(line);
      ASSERT_EQ(cells.size(), 26u) << line;
      EXPECT_EQ(cells[24], "on");
      triangles[reuse].push_back(cells[9]);
      // The first frame has no previous cut to compare with.
      EXPECT_EQ(std::stod(cells[22]) < 0.0, frame == 0) << line;
    }
  }
  EXPECT_EQ(triangles["on"], triangles["off"]);
  EXPECT_EQ(triangles["on"].size(), 21u);
  // The device's draw list (--draws indirect) draws the same triangles, nothing read back.
  for (const std::string draws : {"readback", "indirect"}) {
    SCOPED_TRACE(draws);
    const std::filesystem::path out = dir / ("r-gpu-" + draws);
    std::string command = "bench '" + dataset.string() + "' --path '" + path + "' --out '";
    command += out.string() + "' --prefetch off --selection gpu --draws " + draws;
    command += " --width 320 --height 240 --quiet";
    const CliRun bench = runPbdam(command);
    ASSERT_EQ(bench.exitCode, 0) << bench.err;
    std::ifstream in(out / "summary.json");
    const auto gpuRun = nlohmann::json::parse(in)["runs"][0];
    EXPECT_EQ(gpuRun["selection"], "gpu");
    EXPECT_EQ(gpuRun["draws"], draws);
    // Indirect: the selection and draw-list passes count as upload, so the device is busiest.
    EXPECT_GT(gpuRun["gpu_busy_fraction"].get<double>(), 0.0);
    EXPECT_LE(gpuRun["gpu_busy_fraction"].get<double>(), 1.0);
    // Checked against the host's cut every frame: none differs on lavapipe, and no drawn inner
    // patch's screen error (on the host, in double) is over the tolerance.
    EXPECT_EQ(gpuRun["selection_frames_differing"], 0);
    if (draws == "readback") {
      EXPECT_GT(gpuRun["selection_max_screen_error_ratio"].get<double>(), 0.0);
      EXPECT_LE(gpuRun["selection_max_screen_error_ratio"].get<double>(), 1.0);
    }
    std::istringstream csv(test::readFile(out / "frames.csv"));
    std::string line;
    std::getline(csv, line);
    std::vector<std::string> gpuTriangles;
    while (std::getline(csv, line)) gpuTriangles.push_back(splitCsv(line).at(9));
    EXPECT_EQ(gpuTriangles, triangles["on"]);
  }
  EXPECT_LT(2.0 * decisions["on"], decisions["off"]);
}

// Progress in logs: with stderr a pipe (as under CI or `2>log`), a long bench prints at most one
// progress line a second plus the final one, not one per frame. Lines are counted by '\n' and
// '\r' alike, so a redrawn terminal bar written into the log would count every redraw.
TEST(Cli, BenchProgressInAPipeIsAtMostALineASecond) {
  PBDAM_REQUIRE_DATASET(dataset, "mola");
  test::TempDir dir;
  const std::string path = (dir / "flight.csv").string();
  ASSERT_EQ(runPbdam("path waypoints --via=0,-60,3000e3 --via=-8,-75,50e3 --duration 10 --fps 10 "
                     "--planet mars --out '" +
                     path + "'")
                .exitCode,
            0);
  const std::string command = std::string("'") + PBDAM_EXE + "' bench '" + dataset.string() +
                              "' --path '" + path + "' --out '" + (dir / "r").string() +
                              "' --prefetch off --width 32 --height 24 2>&1 >/dev/null";
  const auto start = std::chrono::steady_clock::now();
  FILE* pipe = ::popen(command.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::string err;
  std::array<char, 4096> buf{};
  std::size_t n = 0;
  while ((n = std::fread(buf.data(), 1, buf.size(), pipe)) > 0) err.append(buf.data(), n);
  const int status = ::pclose(pipe);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << err;
  std::vector<std::string> lines;
  std::string line;
  for (const char c : err) {
    if (c != '\n' && c != '\r') {
      line += c;
      continue;
    }
    // Only progress lines count: sanitizer runtimes add their own summary on stderr.
    if (line.rfind("morph on, prefetch off: frame ", 0) == 0) lines.push_back(line);
    line.clear();
  }
  if (line.rfind("morph on, prefetch off: frame ", 0) == 0) lines.push_back(line);
  ASSERT_FALSE(lines.empty()) << "no progress at all:\n" << err;
  EXPECT_EQ(lines.back().rfind("morph on, prefetch off: frame 101/101 ", 0), 0u) << lines.back();
  // One line at the start, one per full second after it, and the final line.
  EXPECT_LE(static_cast<double>(lines.size()), std::floor(seconds) + 2.0)
      << lines.size() << " lines in " << seconds << " s:\n"
      << err;
  EXPECT_LT(lines.size(), 101u) << "one line per frame";
}

}  // namespace
}  // namespace pbdam::tools
