// `pbdam render` as a user runs it: one camera to PNG and EXR with a statistics line, a camera
// path to numbered frames (and the MP4 through ffmpeg when it is on PATH, skipped otherwise),
// bad input → one clear line on stderr and exit code 2, and so is a dataset truncated on disk.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>

#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "TestData.h"
#include "pbdam/formats/Image.h"

namespace pbdam::tools {
namespace {

using CliRun = test::CommandRun;

/// Runs pbdam with `args` (a shell-quoted string) after `env` (shell assignments), capturing
/// stdout and stderr.
CliRun runPbdam(const std::string& args, const std::string& env = "") {
  return test::runCommand(env + " '" + std::string(PBDAM_EXE) + "' " + args);
}

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

std::string quoted(const std::filesystem::path& p) {
  std::string q = "'";  // built step by step: GCC 12 -O3 warns (-Wrestrict) on "'" + s + "'"
  q += p.string();
  q += '\'';
  return q;
}

constexpr const char* kSmall = " --width 160 --height 90";

TEST(RenderCli, Help) {
  const CliRun run = runPbdam("render --help");
  EXPECT_EQ(run.exitCode, 0) << run.err;
  for (const char* option :
       {"--camera", "--path", "--out", "--width", "--height", "--fov-deg", "--tolerance-px",
        "--gpu-cache-mb", "--device", "--stats", "--clear", "OUT_000000.png"}) {
    EXPECT_NE(run.out.find(option), std::string::npos) << option << "\n" << run.out;
  }
}

TEST(RenderCli, OneCameraToPngWithStats) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  test::TempDir tmp;
  const auto png = tmp / "mars.png";
  const auto stats = tmp / "stats.jsonl";
  const CliRun run = runPbdam("render " + quoted(dir) + " --camera 18.65,226.2,3e6 --out " +
                              quoted(png) + " --stats " + quoted(stats) + kSmall);
  ASSERT_EQ(run.exitCode, 0) << run.err;
  EXPECT_NE(run.out.find("wrote " + png.string()), std::string::npos) << run.out;
  const std::string bytes = test::readFile(png);
  ASSERT_GT(bytes.size(), 8u);
  EXPECT_EQ(bytes.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  const auto statLines = lines(test::readFile(stats));
  ASSERT_EQ(statLines.size(), 1u);
  const auto j = nlohmann::json::parse(statLines[0]);
  for (const char* key :
       {"frame", "patches", "triangles", "tiles", "traversal_ms", "decode_ms", "upload_ms",
        "draw_ms", "resident_bytes", "hits", "misses", "evictions", "bytes_uploaded",
        "budget_exceeded", "morphing_patches", "blending_patches", "largest_morph_weight"}) {
    EXPECT_TRUE(j.contains(key)) << key << " in " << statLines[0];
  }
  EXPECT_EQ(j["frame"], 0);
  EXPECT_GT(j["patches"].get<int>(), 0);
  EXPECT_EQ(j["hits"], 0);
  EXPECT_GT(j["misses"].get<int>(), 0);
  EXPECT_FALSE(j["budget_exceeded"].get<bool>());
  EXPECT_FALSE(std::filesystem::exists(tmp / "mars.partial.png"));
  // Morph off draws the same cut with every vertex at its own height: another image where
  // patches morph, the same triangles.
  const auto flat = tmp / "flat.png";
  const auto flatStats = tmp / "flat.jsonl";
  ASSERT_EQ(runPbdam("render " + quoted(dir) + " --camera 18.65,226.2,3e6 --out " + quoted(flat) +
                     " --stats " + quoted(flatStats) + " --morph off" + kSmall)
                .exitCode,
            0);
  const auto off = nlohmann::json::parse(lines(test::readFile(flatStats))[0]);
  EXPECT_EQ(off["triangles"], j["triangles"]);
  EXPECT_EQ(off["morphing_patches"], 0);
  EXPECT_EQ(off["largest_morph_weight"], 0.0);
  if (j["morphing_patches"].get<int>() > 0) {
    EXPECT_NE(test::readFile(flat), bytes);
  }
}

TEST(RenderCli, OneCameraToExr) {
  PBDAM_REQUIRE_DATASET(dir, "earth");
  test::TempDir tmp;
  const auto exr = tmp / "earth.exr";
  const CliRun run = runPbdam("render " + quoted(dir) + " --camera 40,-100,8e6,0,-90,0 --out " +
                              quoted(exr) + " --quiet --clear 255,0,255" + kSmall);
  ASSERT_EQ(run.exitCode, 0) << run.err;
  EXPECT_TRUE(run.out.empty()) << run.out;
  const std::string bytes = test::readFile(exr);
  ASSERT_GT(bytes.size(), 4u);
  EXPECT_EQ(bytes.substr(0, 4), std::string("\x76\x2f\x31\x01", 4));  // OpenEXR magic
}

// Under the sun with the atmosphere, an EXR frame holds the frame's linear radiance (half floats,
// unclamped) and names its exposure; the PNG of the same camera is its tone-mapped colour.
TEST(RenderCli, AnExrWithTheAtmosphereHoldsItsRadiance) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  test::TempDir tmp;
  const auto exr = tmp / "mars.exr";
  const CliRun run = runPbdam("render " + quoted(dir) + " --camera 0,0,30e3,90,0,0 --out " +
                              quoted(exr) + " --quiet --sun 90,2" + kSmall);
  ASSERT_EQ(run.exitCode, 0) << run.err;
  const std::string bytes = test::readFile(exr);
  ASSERT_GT(bytes.size(), 4u);
  EXPECT_EQ(bytes.substr(0, 4), std::string("\x76\x2f\x31\x01", 4));  // OpenEXR magic
  EXPECT_NE(bytes.find("pbdam:exposure"), std::string::npos) << "not the frame's radiance";
  // Without the atmosphere the EXR is the display colour, with no exposure.
  const auto plain = tmp / "plain.exr";
  const CliRun bare = runPbdam("render " + quoted(dir) + " --camera 0,0,30e3,90,0,0 --out " +
                               quoted(plain) + " --quiet --sun 90,2 --atmosphere off" + kSmall);
  ASSERT_EQ(bare.exitCode, 0) << bare.err;
  EXPECT_EQ(test::readFile(plain).find("pbdam:exposure"), std::string::npos);
}

TEST(RenderCli, CameraPathToFramesAndVideo) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  test::TempDir tmp;
  const auto path = tmp / "path.csv";
  {
    std::ofstream out(path);
    out << "t,lat,lon,alt,heading,pitch,roll\n"
           "0,0,0,4e6,0,-90,0\n"
           "0.25,0,0,4e6,0,-90,0\n"
           "0.5,0,2,4e6,0,-90,0\n";
  }
  // A stand-in ffmpeg that records its arguments and creates the output file.
  const auto bin = tmp / "bin";
  std::filesystem::create_directory(bin);
  {
    std::ofstream script(bin / "ffmpeg");
    script << "#!/bin/sh\necho \"$@\" > '" << (tmp / "ffmpeg-args.txt").string()
           << "'\nfor a; do last=$a; done\n: > \"$last\"\n";
  }
  ::chmod((bin / "ffmpeg").c_str(), 0755);
  const auto stats = tmp / "stats.jsonl";
  const CliRun run = runPbdam("render " + quoted(dir) + " --path " + quoted(path) + " --out " +
                                  quoted(tmp / "flight.png") + " --stats " + quoted(stats) + kSmall,
                              "PATH='" + bin.string() + "':\"$PATH\"");
  ASSERT_EQ(run.exitCode, 0) << run.err;
  for (const char* frame : {"flight_000000.png", "flight_000001.png", "flight_000002.png"}) {
    EXPECT_TRUE(std::filesystem::exists(tmp / frame)) << frame;
  }
  EXPECT_NE(run.out.find("frame 3/3"), std::string::npos) << run.out;
  EXPECT_TRUE(std::filesystem::exists(tmp / "flight.mp4")) << run.out;
  const std::string args = test::readFile(tmp / "ffmpeg-args.txt");
  EXPECT_NE(args.find("-framerate 4 "), std::string::npos) << args;  // 2 intervals in 0.5 s
  EXPECT_NE(args.find((tmp / "flight_%06d.png").string()), std::string::npos) << args;
  const auto statLines = lines(test::readFile(stats));
  ASSERT_EQ(statLines.size(), 3u);
  const auto second = nlohmann::json::parse(statLines[1]);
  EXPECT_EQ(second["frame"], 1);
  EXPECT_EQ(second["misses"], 0);  // the same camera again: all from the GPU cache
  EXPECT_GT(second["hits"].get<int>(), 0);

  // Without ffmpeg on PATH the frames are written and the MP4 is skipped with a message.
  const CliRun bare = runPbdam("render " + quoted(dir) + " --path " + quoted(path) + " --out " +
                                   quoted(tmp / "bare") + kSmall,
                               "PATH=/nonexistent");
  ASSERT_EQ(bare.exitCode, 0) << bare.err;
  EXPECT_TRUE(std::filesystem::exists(tmp / "bare_000002.png"));
  EXPECT_FALSE(std::filesystem::exists(tmp / "bare.mp4"));
  EXPECT_NE(bare.out.find("MP4 skipped"), std::string::npos) << bare.out;
}

/// The mean of R, G and B over a PNG's pixels.
double meanBrightness(const std::filesystem::path& png) {
  auto image = formats::readImage(png);
  EXPECT_TRUE(image.ok()) << png;
  if (!image.ok()) return 0.0;
  double sum = 0.0;
  const std::vector<std::uint8_t>& rgba = image->rgba();
  for (std::size_t i = 0; i < rgba.size(); i += 4) sum += rgba[i] + rgba[i + 1] + rgba[i + 2];
  const std::size_t pixels = rgba.size() / 4;
  return sum / static_cast<double>(pixels * 3);
}

// --time lights Mars by the sun of that instant (Mars24's example B: the sun over 13.42°S,
// 4.706°W): the hemisphere under it is lit, the one opposite gets the night's small ambient,
// where the camera light lights whatever the camera sees. A fixed camera over the midnight
// meridian with --time-scale half a sol per path second flies to noon. The atmosphere's sky is
// drawn under the sun unless --atmosphere off. Bad times, a sun given twice, a bad atmosphere or
// exposure are refused.
TEST(RenderCli, TheSunOfAnInstantLightsTheDayAndAPathFliesToNoon) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  test::TempDir tmp;
  const std::string time = " --time 2004-01-03T13:46:31Z";
  const auto render = [&](const std::string& camera, const std::string& light,
                          const std::string& name) {
    CliRun run = runPbdam("render " + quoted(dir) + " --camera " + camera + light + " --out " +
                          quoted(tmp / name) + kSmall);
    EXPECT_EQ(run.exitCode, 0) << run.err;
    return run;
  };
  // The atmosphere off for the brightness of the surface alone: from the night side the day's
  // limb glows around the disc.
  const std::string bare = " --atmosphere off";
  const CliRun day = render("-13.42,-4.706,8e6", time + bare, "day.png");
  EXPECT_NE(day.out.find("sun over 13.42°S 4.71°W at 2004-01-03T13:46:31Z (Ls 327.3°)"),
            std::string::npos)
      << day.out;
  render("13.42,175.294,8e6", time + bare, "night.png");
  render("13.42,175.294,8e6", "", "camera.png");
  const double dayMean = meanBrightness(tmp / "day.png");
  const double nightMean = meanBrightness(tmp / "night.png");
  EXPECT_GT(nightMean, 0.0);  // the ambient term
  EXPECT_GT(dayMean, 5.0 * nightMean);
  EXPECT_GT(meanBrightness(tmp / "camera.png"), 5.0 * nightMean);

  const auto path = tmp / "noon.csv";
  {
    std::ofstream out(path);
    out << "t,lat,lon,alt,heading,pitch,roll\n0,0,175.294,8e6,0,-90,0\n1,0,175.294,8e6,0,-90,0\n";
  }
  const CliRun noon = runPbdam("render " + quoted(dir) + " --path " + quoted(path) + time + bare +
                                   " --time-scale 44387.622 --out " + quoted(tmp / "noon") + kSmall,
                               "PATH=/nonexistent");
  ASSERT_EQ(noon.exitCode, 0) << noon.err;
  EXPECT_GT(meanBrightness(tmp / "noon_000001.png"), 5.0 * meanBrightness(tmp / "noon_000000.png"));

  // Under the sun the atmosphere is on by default: the sky above a low camera is lit; off, it is
  // the black background.
  const auto topRow = [](const std::filesystem::path& png) {
    auto image = formats::readImage(png);
    EXPECT_TRUE(image.ok()) << png;
    double sum = 0.0;
    if (!image.ok()) return sum;
    for (std::int64_t x = 0; x < image->width(); ++x) {
      const auto p = image->pixel(x, 1);
      sum += p[0] + p[1] + p[2];
    }
    return sum;
  };
  render("-10,-68,10e3,90,5,0", time, "sky.png");
  render("-10,-68,10e3,90,5,0", time + " --atmosphere off", "nosky.png");
  EXPECT_GT(topRow(tmp / "sky.png"), 0.0);
  EXPECT_EQ(topRow(tmp / "nosky.png"), 0.0);

  for (const auto& [args, message] : std::vector<std::pair<std::string, std::string>>{
           {" --atmosphere thick", "--atmosphere ('thick'): expected auto, on or off"},
           {" --exposure -1", "--exposure must be a number in (0, 1e6]"},
           {" --time 2004-02-30T00:00Z", "--time: time '2004-02-30T00:00Z': no such date"},
           {" --time yesterday", "--time: time 'yesterday'"},
           {time + " --sun 90,10", "--sun ('90,10') and --time"},
           {" --sun 90,91", "--sun ('90,91'): expected camera or AZ,EL"},
           {" --ambient 1.5", "--ambient must be in 0..1"}}) {
    const CliRun bad = runPbdam("render " + quoted(dir) + " --camera 0,0,8e6" + args + " --out " +
                                quoted(tmp / "bad.png") + kSmall);
    EXPECT_EQ(bad.exitCode, 2) << args;
    EXPECT_NE(bad.err.find(message), std::string::npos) << args << ": " << bad.err;
    EXPECT_FALSE(std::filesystem::exists(tmp / "bad.png")) << args;
  }
}

// A path drawn with 1, 2 and 3 frames in flight (frames encoded on writer threads): the same
// PNG bytes and the same per-frame statistics, in frame order, whatever is in flight; under a
// GPU cache budget small enough that frames evict what the frames before them drew.
TEST(RenderCli, FramesInFlightWriteTheSameFrames) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  test::TempDir tmp;
  const auto path = tmp / "path.csv";
  {
    std::ofstream out(path);
    out << "t,lat,lon,alt,heading,pitch,roll\n";
    for (int k = 0; k < 10; ++k) {
      out << 0.1 * k << "," << -10 + 2 * k << "," << 280 + 3 * k << "," << 800e3 - 50e3 * k
          << ",70,-40,0\n";
    }
  }
  // 5 MiB: frames evict what earlier frames drew; 3 MiB: each frame takes two passes too.
  for (const char* budget : {"5", "3"}) {
    SCOPED_TRACE(std::string(budget) + " MiB");
    std::map<int, std::vector<std::string>> images;
    std::map<int, std::vector<std::string>> stats;
    std::uint64_t evictions = 0;
    for (const int inFlight : {1, 2, 3}) {
      const auto prefix = tmp / ("f" + std::to_string(inFlight) + "-" + budget);
      const auto statsFile = tmp / ("stats" + std::to_string(inFlight) + "-" + budget + ".jsonl");
      const CliRun run =
          runPbdam("render " + quoted(dir) + " --path " + quoted(path) + " --out " +
                       quoted(prefix) + " --stats " + quoted(statsFile) + " --frames-in-flight " +
                       std::to_string(inFlight) + " --gpu-cache-mib " + budget + kSmall,
                   "PATH=/nonexistent");
      ASSERT_EQ(run.exitCode, 0) << run.err;
      for (int k = 0; k < 10; ++k) {
        char name[32];
        std::snprintf(name, sizeof name, "_%06d.png", k);
        images[inFlight].push_back(test::readFile(prefix.string() + name));
      }
      for (const std::string& line : lines(test::readFile(statsFile))) {
        auto j = nlohmann::json::parse(line);
        evictions += j["evictions"].get<std::uint64_t>();
        for (const char* timing :
             {"traversal_ms", "decode_ms", "upload_ms", "draw_ms", "frame_ms"}) {
          j.erase(timing);
        }
        stats[inFlight].push_back(j.dump());
      }
    }
    ASSERT_EQ(stats[1].size(), 10u);
    for (const int inFlight : {2, 3}) {
      for (std::size_t k = 0; k < 10; ++k) {
        EXPECT_FALSE(images[1][k].empty());
        EXPECT_TRUE(images[inFlight][k] == images[1][k])
            << "frame " << k << " with " << inFlight << " in flight";
        EXPECT_EQ(stats[inFlight][k], stats[1][k]) << inFlight << " in flight";
      }
    }
    EXPECT_GT(evictions, 30u);
  }
}

// With stdout a pipe (a log), a camera path's per-frame statistics lines come at most one a
// second plus the last frame's, not one per frame (--stats has every frame).
TEST(RenderCli, APathInALogPrintsAtMostALineASecond) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  test::TempDir tmp;
  const auto path = tmp / "path.csv";
  {
    std::ofstream out(path);
    out << "t,lat,lon,alt,heading,pitch,roll\n";
    for (int i = 0; i < 60; ++i) out << i * 0.1 << ",0," << i * 0.05 << ",4e6,0,-90,0\n";
  }
  const auto start = std::chrono::steady_clock::now();
  const CliRun run = runPbdam("render " + quoted(dir) + " --path " + quoted(path) + " --out " +
                                  quoted(tmp / "f") + " --width 32 --height 24",
                              "PATH=/nonexistent");
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_EQ(run.exitCode, 0) << run.err;
  ASSERT_TRUE(std::filesystem::exists(tmp / "f_000059.png"));
  std::vector<std::string> frameLines;
  for (const std::string& line : lines(run.out)) {
    if (line.rfind("frame ", 0) == 0) frameLines.push_back(line);
  }
  ASSERT_FALSE(frameLines.empty()) << run.out;
  EXPECT_EQ(frameLines.back().rfind("frame 60/60 ", 0), 0u) << run.out;
  // One line at the start, one per full second after it, and the last frame's.
  EXPECT_LE(static_cast<double>(frameLines.size()), std::floor(seconds) + 2.0)
      << frameLines.size() << " lines in " << seconds << " s:\n"
      << run.out;
}

TEST(RenderCli, ABudgetOverTheCutStillRenders) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  test::TempDir tmp;
  const auto stats = tmp / "stats.jsonl";
  const CliRun run =
      runPbdam("render " + quoted(dir) + " --camera 0,0,4e6 --out " + quoted(tmp / "a.png") +
               " --gpu-cache-mb 0.5 --stats " + quoted(stats) + kSmall);
  ASSERT_EQ(run.exitCode, 0) << run.err;
  EXPECT_NE(run.err.find("warning"), std::string::npos) << run.err;
  EXPECT_TRUE(nlohmann::json::parse(test::readFile(stats))["budget_exceeded"].get<bool>());
}

// The device's selection passes draw the host's cut: byte-identical exact frames, with and
// without a focus circle.
TEST(RenderCli, GpuSelectionDrawsTheSameFrameAsTheCpu) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  test::TempDir tmp;
  for (const std::string focus : {"", " --focus 18.65,226.2,100e3"}) {
    std::string frames[2];
    for (int k = 0; k < 2; ++k) {
      const auto png = tmp / (std::to_string(k) + ".png");
      const CliRun run =
          runPbdam("render " + quoted(dir) + " --camera 18.65,226.2,600e3,0,-60,0" + focus +
                   " --selection " + (k == 0 ? "cpu" : "gpu") + " --out " + quoted(png) + kSmall);
      ASSERT_EQ(run.exitCode, 0) << run.err;
      frames[k] = test::readFile(png);
    }
    EXPECT_EQ(frames[0], frames[1]) << "focus '" << focus << "'";
  }
}

// --exaggeration 1 is today's frame byte for byte; five-fold heights draw another frame of the
// same camera (Olympus Mons, low and looking at it).
TEST(RenderCli, ExaggerationOneIsTheTrueFrameByteForByte) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  test::TempDir tmp;
  for (const std::string camera : {"18.65,226.2,600e3,0,-60,0", "15.4,226.2,160e3,0,-5,0"}) {
    std::string frames[3];
    const std::string flags[3] = {"", " --exaggeration 1", " --exaggeration 5"};
    for (int k = 0; k < 3; ++k) {
      const auto png = tmp / (std::to_string(k) + ".png");
      const CliRun run = runPbdam("render " + quoted(dir) + " --camera " + camera + flags[k] +
                                  " --out " + quoted(png) + kSmall);
      ASSERT_EQ(run.exitCode, 0) << run.err;
      frames[k] = test::readFile(png);
    }
    EXPECT_EQ(frames[0], frames[1]) << camera;
    EXPECT_NE(frames[0], frames[2]) << camera;
  }
}

// Out of (0, 100] or not a number: one line naming --exaggeration, exit code 2, before any
// dataset is read (render, bench, fly). The queries keep true heights and do not take it.
TEST(RenderCli, ABadExaggerationIsExitCode2NamingIt) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  test::TempDir tmp;
  const std::string ds = quoted(dir);
  for (const std::string value : {"0", "-1", "nan", "1000", "inf"}) {
    for (const std::string& command :
         {"render " + ds + " --camera 0,0,1e6 --out " + quoted(tmp / "x.png"),
          "bench " + ds + " --path " + quoted(tmp / "none.csv") + " --out " +
              quoted(tmp / "b.json"),
          "fly " + ds}) {
      std::string args = command;
      args += " --exaggeration ";
      args += value;
      const CliRun run = runPbdam(args);
      EXPECT_EQ(run.exitCode, 2) << args << "\n" << run.err;
      EXPECT_EQ(lines(run.err).size(), 1u) << args << "\n" << run.err;
      EXPECT_NE(run.err.find("--exaggeration " + value), std::string::npos) << args << "\n"
                                                                            << run.err;
    }
  }
  EXPECT_FALSE(std::filesystem::exists(tmp / "x.png"));
  // pbdam height reports true heights and has no such option.
  const CliRun plain = runPbdam("height " + ds + " --at 18.65,226.2");
  ASSERT_EQ(plain.exitCode, 0) << plain.err;
  const CliRun refused = runPbdam("height " + ds + " --at 18.65,226.2 --exaggeration 3");
  EXPECT_EQ(refused.exitCode, 2) << refused.out;
  EXPECT_NE(refused.err.find("--exaggeration"), std::string::npos) << refused.err;
  EXPECT_EQ(refused.out, "");
}

// --viewshed drapes the eye's viewshed over the terrain: the frame changes where the disc is in
// view, the same request draws the same bytes, and a view of the other side of the planet is
// the plain frame byte for byte (the overlay touches nothing outside its disc).
TEST(RenderCli, AViewshedIsDrapedOverItsDiscOnly) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  test::TempDir tmp;
  const auto render = [&](const std::string& camera, const std::string& extra,
                          const std::string& name) {
    const auto png = tmp / name;
    const CliRun run = runPbdam("render " + quoted(dir) + " --camera " + camera + extra +
                                " --out " + quoted(png) + kSmall);
    EXPECT_EQ(run.exitCode, 0) << run.err;
    return test::readFile(png);
  };
  const std::string over = "16,-133.8,600e3,0,-60,0";
  const std::string away = "-16,46.2,600e3,0,-60,0";
  const std::string viewshed = " --viewshed 18.65,226.2,3000,300000";
  const std::string plain = render(over, "", "plain.png");
  const std::string draped = render(over, viewshed, "draped.png");
  EXPECT_NE(plain, draped);
  EXPECT_EQ(draped, render(over, viewshed, "again.png"));
  EXPECT_EQ(render(away, "", "away.png"), render(away, viewshed, "away_draped.png"));
  const CliRun bad = runPbdam("render " + quoted(dir) + " --camera " + over +
                              " --viewshed 18.65,226.2 --out " + quoted(tmp / "bad.png") + kSmall);
  EXPECT_EQ(bad.exitCode, 2);
  EXPECT_NE(bad.err.find("--viewshed '18.65,226.2'"), std::string::npos) << bad.err;
  const CliRun under =
      runPbdam("render " + quoted(dir) + " --camera " + over + " --viewshed 18.65,226.2,-5 --out " +
               quoted(tmp / "bad.png") + kSmall);
  EXPECT_EQ(under.exitCode, 2);
  EXPECT_NE(under.err.find("underground"), std::string::npos) << under.err;
}

TEST(RenderCli, BadInputIsOneLineAndExitCode2) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  test::TempDir tmp;
  const std::string ds = quoted(dir);
  const std::string out = " --out " + quoted(tmp / "x.png");
  {
    std::ofstream bad(tmp / "bad.csv");
    bad << "t,lat,lon,alt,heading,pitch,roll\n0,0,0,1e6,0,-90,0\n0,0,0,1e6,0,-90,0\n";
    std::ofstream far(tmp / "far.csv");
    far << "t,lat,lon,alt,heading,pitch,roll\n0,0,0,1e6,0,-90,0\n1,95,0,1e6,0,-90,0\n";
  }
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"render " + quoted(tmp / "missing") + " --camera 0,0,1e6" + out, "missing"},
      {"render " + ds + out, "exactly one of --camera"},
      {"render " + ds + " --camera 0,0,1e6 --path " + quoted(tmp / "bad.csv") + out,
       "exactly one of --camera"},
      {"render " + ds + " --camera 0,0" + out, "camera '0,0'"},
      {"render " + ds + " --camera 100,0,1e6" + out, "latitude"},
      {"render " + ds + " --camera 0,0,1e6 --width 0" + out, "image size"},
      {"render " + ds + " --camera 0,0,1e6 --height 20000" + out, "image size"},
      {"render " + ds + " --camera 0,0,1e6 --width -4" + out, "--width"},
      {"render " + ds + " --camera 0,0,1e6 --fov-deg 180" + out, "field of view"},
      {"render " + ds + " --camera 0,0,1e6 --tolerance-px 0" + out, "--tolerance-px"},
      {"render " + ds + " --camera 0,0,1e6 --gpu-cache-mb 0" + out, "--gpu-cache-mb"},
      {"render " + ds + " --camera 0,0,1e6 --gpu-cache-mb 0.01" + out, "minimum of"},
      {"render " + ds + " --camera 0,0,1e6 --clear 255,0" + out, "--clear"},
      {"render " + ds + " --camera 0,0,1e6 --frames-in-flight 0" + out, "--frames-in-flight"},
      {"render " + ds + " --camera 0,0,1e6 --frames-in-flight 9" + out, "1..8"},
      {"render " + ds + " --camera 0,0,1e6 --clear 256,0,0" + out, "--clear"},
      {"render " + ds + " --camera 0,0,1e6 --out " + quoted(tmp / "x.jpg"), ".png or .exr"},
      {"render " + ds + " --camera 0,0,1e6 --out " + quoted(tmp / "no/such/dir/x.png"),
       "does not exist"},
      {"render " + ds + " --camera 0,0,1e6 --device 99" + out, "device index 99"},
      {"render " + ds + " --camera 0,0,1e6 --device no-such-gpu" + out,
       "no Vulkan device matches 'no-such-gpu'"},
      {"render " + ds + " --path " + quoted(tmp / "none.csv") + out, "none.csv"},
      {"render " + ds + " --path " + quoted(tmp / "bad.csv") + out, "bad.csv:3:"},
      {"render " + ds + " --path " + quoted(tmp / "far.csv") + out, "row 2"},
      {"render " + ds + " --camera 0,0,1e6", "--out"},
      {"render " + ds + " --camera 0,0,1e6 --morph maybe" + out, "--morph 'maybe'"},
      {"render " + ds + " --camera 0,0,1e6 --selection tpu" + out, "--selection 'tpu'"},
      {"render " + ds + " --camera 0,0,1e6 --morph-range 0" + out, "--morph-range"},
      {"render " + ds + " --camera 0,0,1e6 --morph-range 0.5" + out, "error margin"},
      {"render " + ds + " --camera 0,0,1e6 --focus 10,20" + out, "--focus '10,20'"},
      {"render " + ds + " --camera 0,0,1e6 --focus 95,0,1000" + out, "latitude"},
      {"render " + ds + " --camera 0,0,1e6 --focus 0,0,0" + out, "radius"},
      {"render " + ds + " --camera 0,0,1e6 --focus 0,0,1000 --focus-error-m -1" + out, "error"},
  };
  for (const auto& [args, expected] : cases) {
    const CliRun run = runPbdam(args);
    EXPECT_EQ(run.exitCode, 2) << args << "\n" << run.err;
    EXPECT_EQ(lines(run.err).size(), 1u) << args << "\n" << run.err;
    EXPECT_EQ(run.err.rfind("pbdam: ", 0), 0u) << args << "\n" << run.err;
    EXPECT_NE(run.err.find(expected), std::string::npos) << args << "\n" << run.err;
  }
  EXPECT_FALSE(std::filesystem::exists(tmp / "x.png"));
}

// A face file truncated in place (a failing disk, a half-finished copy): every command that
// reads the dataset says which file and where, and exits 2 — never a SIGBUS.
TEST(RenderCli, ATruncatedDatasetIsExitCode2NamingFileAndOffset) {
  PBDAM_REQUIRE_DATASET(shared, "mola");
  test::TempDir temp;
  const std::filesystem::path dir = temp / "mola";
  std::filesystem::copy(shared, dir);
  const std::filesystem::path face = dir / "face3.pbdam";
  std::filesystem::resize_file(face, std::filesystem::file_size(face) / 2);
  const std::string png = (temp / "frame.png").string();
  for (const std::string& args :
       {"render " + quoted(dir) + " --camera 0,0,4e6 --out '" + png + "'" + kSmall,
        "height " + quoted(dir) + " --at 18.4,-133.9", "info " + quoted(dir),
        "verify " + quoted(dir)}) {
    SCOPED_TRACE(args);
    const CliRun run = runPbdam(args);
    EXPECT_EQ(run.exitCode, 2) << run.err;
    EXPECT_NE(run.err.find("face3.pbdam"), std::string::npos) << run.err;
    EXPECT_NE(run.err.find("offset"), std::string::npos) << run.err;
  }
}

}  // namespace
}  // namespace pbdam::tools
