// `pbdam fly`: the controls and the script format on their own, then the command as a user runs
// it — under Xvfb with lavapipe and validation on, a scripted flight that flies, resizes once,
// takes two screenshots and records its path; the screenshots are `pbdam render`'s bytes for
// the same cameras, the recorded path replays in `pbdam bench` and in the window — and bad input
// (no dataset, no display, a bad script) exits 2 with the reason before any window opens.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "FlyControls.h"
#include "TestData.h"
#include "pbdam/formats/CameraPath.h"

namespace pbdam::tools {
namespace {

namespace fs = std::filesystem;
using runtime::CameraPose;

constexpr double kMarsRadius = 3396190.0;

FlyControls flatControls(const CameraPose& start, double ground = 1000.0) {
  return FlyControls(start, kMarsRadius,
                     [ground](double, double) -> std::optional<double> { return ground; });
}

TEST(FlyControls, HeldKeysMoveTurnAndClimbAtSpeedsThatScaleWithTheHeight) {
  FlyControls c = flatControls({10.0, 20.0, 11000.0, 0.0, -30.0, 0.0});
  EXPECT_DOUBLE_EQ(c.heightAboveGround(), 10000.0);
  c.press(FlyKey::W);
  c.update(1.0);  // 0.8 x 10 km north in one second
  c.release(FlyKey::W);
  EXPECT_NEAR((c.pose().latDegrees - 10.0) * kMarsRadius * M_PI / 180.0, 8000.0, 1.0);
  EXPECT_DOUBLE_EQ(c.pose().lonDegrees, 20.0);
  c.press(FlyKey::Right);
  c.update(0.5);
  c.release(FlyKey::Right);
  EXPECT_DOUBLE_EQ(c.pose().headingDegrees, 30.0);
  c.press(FlyKey::E);
  c.update(1.0);
  c.release(FlyKey::E);
  EXPECT_NEAR(c.heightAboveGround(), 18000.0, 1e-6);
  c.update(1.0);  // nothing held: nothing moves
  EXPECT_NEAR(c.heightAboveGround(), 18000.0, 1e-6);
}

TEST(FlyControls, NeverBelowTheGroundWhateverTheInput) {
  double ground = 500.0;
  FlyControls c(
      CameraPose{0.0, 0.0, 600.0, 90.0, -10.0, 0.0}, kMarsRadius,
      [&ground](double, double) -> std::optional<double> { return ground; }, 2.0);
  c.wheel(100.0);  // far down
  EXPECT_DOUBLE_EQ(c.pose().altitudeMeters, 502.0);
  c.press(FlyKey::Q);
  c.update(10.0);
  EXPECT_DOUBLE_EQ(c.pose().altitudeMeters, 502.0);
  c.release(FlyKey::Q);
  ground = 2000.0;  // the ground rises under the camera
  c.press(FlyKey::D);
  c.update(0.1);
  EXPECT_GE(c.pose().altitudeMeters, 2002.0);
  c.setPose({0.0, 0.0, -100.0, 0.0, -90.0, 0.0});
  EXPECT_DOUBLE_EQ(c.pose().altitudeMeters, 2002.0);
}

TEST(FlyControls, DragPitchClampsAndGoToKeepsTheHeight) {
  FlyControls c = flatControls({0.0, 0.0, 6000.0, 350.0, -30.0, 0.0});
  c.drag(100.0, 0.0);  // 20 degrees right, across north
  EXPECT_NEAR(c.pose().headingDegrees, 10.0, 1e-9);
  c.drag(0.0, -1000.0);  // up to the limit
  EXPECT_DOUBLE_EQ(c.pose().pitchDegrees, 30.0);
  c.press(FlyKey::G);
  c.type("18.65,-133.8");
  c.press(FlyKey::Enter);
  EXPECT_FALSE(c.typing);
  EXPECT_TRUE(c.message.empty()) << c.message;
  EXPECT_DOUBLE_EQ(c.pose().latDegrees, 18.65);
  EXPECT_DOUBLE_EQ(c.pose().lonDegrees, -133.8);
  EXPECT_DOUBLE_EQ(c.heightAboveGround(), 5000.0);
  c.press(FlyKey::G);
  c.type("north");  // letters are not part of a place
  c.type("95,0");
  c.press(FlyKey::Enter);
  EXPECT_NE(c.message.find("latitude"), std::string::npos) << c.message;
  EXPECT_DOUBLE_EQ(c.pose().latDegrees, 18.65);
}

TEST(FlyControls, TogglesAndScreenshots) {
  FlyControls c = flatControls({0.0, 0.0, 6000.0, 0.0, -90.0, 0.0});
  EXPECT_TRUE(c.morph);
  c.press(FlyKey::M);
  EXPECT_FALSE(c.morph);
  c.press(FlyKey::H);
  EXPECT_FALSE(c.hud);
  c.press(FlyKey::F1);
  EXPECT_TRUE(c.help);
  c.press(FlyKey::P);
  c.press(FlyKey::P);
  EXPECT_EQ(c.screenshotsWanted, 2);
  c.press(FlyKey::V);
  EXPECT_TRUE(c.viewshed);
  // [ and ] move the sun's time by an hour.
  c.press(FlyKey::BracketRight);
  c.press(FlyKey::BracketRight);
  c.press(FlyKey::BracketLeft);
  EXPECT_DOUBLE_EQ(c.sunHours, 1.0);
  EXPECT_EQ(parseFlyKey("["), FlyKey::BracketLeft);
  EXPECT_EQ(parseFlyKey("]"), FlyKey::BracketRight);
}

TEST(FlyScript, ParsesEveryActionAndNamesTheLineOfAnError) {
  auto events = parseFlyScript(
      "# a comment\n0.5 key w down\n1 key w up\n1 key p\n2 drag 10 -5\n2.5 wheel -2\n"
      "3 type 18.6,-133.8\n4 resize 800 600\n\n5 close  # done\n",
      "s.txt");
  ASSERT_TRUE(events.ok()) << events.error().message;
  ASSERT_EQ(events->size(), 8u);
  EXPECT_EQ((*events)[0].kind, FlyScriptEvent::Kind::KeyDown);
  EXPECT_EQ((*events)[0].key, FlyKey::W);
  EXPECT_EQ((*events)[2].kind, FlyScriptEvent::Kind::KeyTap);
  EXPECT_EQ((*events)[3].kind, FlyScriptEvent::Kind::Drag);
  EXPECT_DOUBLE_EQ((*events)[3].y, -5.0);
  EXPECT_EQ((*events)[5].text, "18.6,-133.8");
  EXPECT_EQ((*events)[6].kind, FlyScriptEvent::Kind::Resize);
  EXPECT_DOUBLE_EQ((*events)[7].tSeconds, 5.0);
  for (const auto& [text, what] : std::vector<std::pair<std::string, std::string>>{
           {"1 key w\n0.5 key a\n", "s.txt:2: times must not decrease"},
           {"x key w\n", "s.txt:1: expected a time"},
           {"1 key z\n", "s.txt:1: unknown key \"z\""},
           {"1 key w sideways\n", "s.txt:1: expected down or up"},
           {"1 jump\n", "s.txt:1: unknown action \"jump\""},
           {"1 resize 0 600\n", "s.txt:1: expected resize WIDTH HEIGHT"},
           {"1 drag 3\n", "s.txt:1: expected drag DX DY"},
       }) {
    auto bad = parseFlyScript(text, "s.txt");
    ASSERT_FALSE(bad.ok()) << text;
    EXPECT_NE(bad.error().message.find(what), std::string::npos) << bad.error().message;
  }
}

std::string quoted(const std::string& text) {
  std::string q = "'";  // built step by step: GCC 12 -O3 warns (-Wrestrict) on "'" + s + "'"
  q += text;
  q += '\'';
  return q;
}

test::CommandRun runPbdam(const std::string& args, const std::string& env = "") {
  return test::runCommand(env + " " + quoted(PBDAM_EXE) + " " + args);
}

/// pbdam fly under its own Xvfb screen (xvfb-run picks a free display number).
test::CommandRun runFly(const std::string& args) {
  return test::runCommand("xvfb-run -a -s '-screen 0 1600x1000x24' " + quoted(PBDAM_EXE) + " fly " +
                          args);
}

bool haveXvfb() { return test::runCommand("command -v xvfb-run").exitCode == 0; }

TEST(FlyCli, HelpListsTheOptions) {
  const auto run = runPbdam("fly --help");
  EXPECT_EQ(run.exitCode, 0) << run.err;
  for (const char* option :
       {"--width",  "--height",   "--fullscreen", "--device",        "--tolerance-px",
        "--morph",  "--camera",   "--goto",       "--gpu-cache-mib", "--present",
        "--record", "--replay",   "--script",     "--exit-after-s",  "--frames-in-flight",
        "--mode",   "--prefetch", "--time",       "--sun",           "--time-scale",
        "--ambient"}) {
    EXPECT_NE(run.out.find(option), std::string::npos) << option;
  }
}

TEST(FlyCli, BadInputExitsTwoBeforeAnyWindow) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const test::TempDir tmp;
  const fs::path& work = tmp.path();
  const std::string ds = quoted(dir.string());
  // No display: said so, and the dataset is checked before (a bad one is named first).
  auto run = runPbdam("fly " + ds, "env -u DISPLAY -u WAYLAND_DISPLAY");
  EXPECT_EQ(run.exitCode, 2);
  EXPECT_NE(run.err.find("no display"), std::string::npos) << run.err;
  run = runPbdam("fly " + quoted((work / "nothing").string()), "env -u DISPLAY -u WAYLAND_DISPLAY");
  EXPECT_EQ(run.exitCode, 2);
  EXPECT_NE(run.err.find("nothing"), std::string::npos) << run.err;
  std::ofstream(work / "script.txt") << "0.5 key w down\n0.2 key w up\n";
  run = runPbdam("fly " + ds + " --script " + quoted((work / "script.txt").string()),
                 "env -u DISPLAY -u WAYLAND_DISPLAY");
  EXPECT_EQ(run.exitCode, 2);
  EXPECT_NE(run.err.find("script.txt:2: times must not decrease"), std::string::npos) << run.err;
  for (const char* options :
       {"--present vsync", "--frames-in-flight 0", "--width 5", "--mode sometimes",
        "--camera 95,0,1e6", "--goto north", "--time 2024-13-01", "--sun 10,100"}) {
    run = runPbdam("fly " + ds + " " + options, "env -u DISPLAY -u WAYLAND_DISPLAY");
    EXPECT_EQ(run.exitCode, 2) << options;
    EXPECT_EQ(run.err.find("no display"), std::string::npos) << options << ": " << run.err;
  }
}

TEST(FlyCli, AScriptedFlightRecordsAndItsScreenshotsAreTheRenderedBytes) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  if (!haveXvfb()) {
    if (test::runningInCi()) FAIL() << "xvfb-run is missing (scripts/setup_test.sh installs it)";
    GTEST_SKIP() << "xvfb-run is not installed";
  }
  const test::TempDir tmp;
  const fs::path& work = tmp.path();
  const std::string ds = quoted(dir.string());
  const fs::path recorded = work / "flight.csv";
  const fs::path stats = work / "stats.json";
  const auto run = runFly(ds + " --camera=-8,-75,300000,90,-35,0 --validation --script " +
                          quoted(PBDAM_FLY_SCRIPT) + " --record " + quoted(recorded.string()) +
                          " --screenshots " + quoted((work / "shot").string()) + " --stats " +
                          quoted(stats.string()));
  ASSERT_EQ(run.exitCode, 0) << run.out << run.err;
  EXPECT_EQ(run.err.find("validation messages"), std::string::npos) << run.err;

  const auto summary = nlohmann::json::parse(test::readFile(stats));
  EXPECT_GE(summary["frames"].get<int>(), 20);
  // The script resized the window: the last frames are the new size.
  EXPECT_EQ(summary["width"].get<int>(), 960);
  EXPECT_EQ(summary["height"].get<int>(), 540);
  EXPECT_EQ(summary["screenshots"].get<int>(), 2);

  // One row a shown frame, flown: it moved east, then went to Olympus Mons (G).
  auto path = formats::readCameraPath(recorded);
  ASSERT_TRUE(path.ok()) << path.error().message;
  EXPECT_EQ(path->size(), summary["frames"].get<std::size_t>());
  EXPECT_NEAR(path->back().latDegrees, 18.65, 1e-9);
  EXPECT_NEAR(path->back().lonDegrees, -133.8, 1e-9);
  bool movedEast = false;
  for (const auto& p : *path) movedEast = movedEast || (p.lonDegrees > -74.0 && p.lonDegrees < 0);
  EXPECT_TRUE(movedEast);

  // Each screenshot is what pbdam render writes for its camera and options.
  for (const char* name : {"shot_000.png", "shot_001.png"}) {
    SCOPED_TRACE(name);
    const std::string options = test::readFile(work / (std::string(name) + ".txt"));
    ASSERT_FALSE(options.empty());
    const fs::path rendered = work / (std::string("render_") + name);
    const auto render = runPbdam("render " + ds + " " + options.substr(0, options.find('\n')) +
                                 " --quiet --out " + quoted(rendered.string()));
    ASSERT_EQ(render.exitCode, 0) << render.err;
    const std::string a = test::readFile(work / name);
    ASSERT_FALSE(a.empty());
    EXPECT_TRUE(a == test::readFile(rendered))
        << "the screenshot differs from pbdam render's frame";
  }

  // The recorded path replays unchanged in pbdam bench...
  const auto bench =
      runPbdam("bench " + ds + " --path " + quoted(recorded.string()) + " --out " +
               quoted((work / "bench").string()) + " --mode no-stall --prefetch on --quiet");
  ASSERT_EQ(bench.exitCode, 0) << bench.err;
  const auto benchSummary = nlohmann::json::parse(test::readFile(work / "bench" / "summary.json"));
  EXPECT_EQ(benchSummary["runs"][0]["frames"].get<std::size_t>(), path->size());

  // ... and in the window. The replay runs in real time, so it shows as many frames as the machine
  // draws in the flight's ten seconds: the whole flight, not its first seconds, so that a slow
  // first frame (TSan, a loaded machine) still leaves several.
  const auto replay = runFly(ds + " --validation --replay " + quoted(recorded.string()) +
                             " --stats " + quoted((work / "replay.json").string()));
  ASSERT_EQ(replay.exitCode, 0) << replay.out << replay.err;
  EXPECT_GE(nlohmann::json::parse(test::readFile(work / "replay.json"))["frames"].get<int>(), 3);
}

}  // namespace
}  // namespace pbdam::tools
