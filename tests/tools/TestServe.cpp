// `pbdam serve` as a client sees it, one request at a time: frames equal `pbdam render`'s PNG for
// the same camera byte for byte (with exaggeration, without the atmosphere); malformed requests
// get a 4xx with a JSON body; /info, /height, /stats, /healthz, the viewer page, and the terrain
// queries /los and /viewshed answer as the command line does. The server runs as its own process
// (ServeTestSupport.h); TestServeOperations.cpp has it under load, on SIGTERM and across reloads.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <httplib.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "ServeTestSupport.h"
#include "TestData.h"

namespace pbdam::tools {
namespace {

using namespace std::chrono_literals;
using namespace serve_test;

/// Runs `pbdam ARGS` capturing stdout and stderr.
test::CommandRun capturePbdam(const std::string& args) {
  return test::runCommand(quoted(PBDAM_EXE) + " " + args);
}

/// Sends `raw` bytes on a fresh connection and returns what comes back until the server
/// closes or 10 s pass.
std::string rawExchange(int port, const std::string& raw) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    ::close(fd);
    return {};
  }
  (void)::send(fd, raw.data(), raw.size(), MSG_NOSIGNAL);
  std::string reply;
  const auto until = std::chrono::steady_clock::now() + 10s;
  while (std::chrono::steady_clock::now() < until) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 200) <= 0) continue;
    std::array<char, 4096> buf{};
    const ssize_t n = ::recv(fd, buf.data(), buf.size(), 0);
    if (n <= 0) break;
    reply.append(buf.data(), static_cast<std::size_t>(n));
    if (reply.find("\r\n\r\n") != std::string::npos && reply.find('}') != std::string::npos) break;
  }
  ::close(fd);
  return reply;
}

void expectJsonError(const httplib::Result& res, const std::string& what) {
  ASSERT_TRUE(res) << what << ": no response (" << httplib::to_string(res.error()) << ")";
  EXPECT_GE(res->status, 400) << what;
  EXPECT_LT(res->status, 500) << what << ": " << res->body;
  EXPECT_EQ(res->get_header_value("Content-Type"), "application/json") << what;
  const auto j = nlohmann::json::parse(res->body, nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << what << ": not JSON: " << res->body;
  EXPECT_EQ(j.value("status", 0), res->status) << what;
  EXPECT_FALSE(j.value("message", std::string()).empty()) << what << ": " << res->body;
}

TEST(ServeCli, Help) {
  const std::string command = quoted(PBDAM_EXE) + " serve --help";
  FILE* pipe = ::popen(command.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::string out;
  std::array<char, 4096> buf{};
  std::size_t n = 0;
  while ((n = std::fread(buf.data(), 1, buf.size(), pipe)) > 0) out.append(buf.data(), n);
  const int status = ::pclose(pipe);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  for (const char* option :
       {"--bind", "--port", "--workers", "--queue", "--gpu-cache-mb", "--deadline-s",
        "--frames-in-flight", "/frame", "/height", "/stats", "/healthz"}) {
    EXPECT_NE(out.find(option), std::string::npos) << option << "\n" << out;
  }
}

TEST(ServeCli, BadOptionsExitWithCode2) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const std::string d = quoted(dir.string());
  EXPECT_EQ(runPbdam("serve " + d + " --port 70000"), 2);
  EXPECT_EQ(runPbdam("serve " + d + " --workers 0"), 2);
  EXPECT_EQ(runPbdam("serve " + d + " --gpu-cache-mb -1"), 2);
  EXPECT_EQ(runPbdam("serve " + d + " --deadline-s 0"), 2);
  EXPECT_EQ(runPbdam("serve " + d + " --frames-in-flight 0"), 2);
  EXPECT_EQ(runPbdam("serve " + d + " --frames-in-flight 9"), 2);
  EXPECT_EQ(runPbdam("serve /nonexistent/dataset --port 0"), 2);
  // Two contexts cannot share 1 MiB: below the per-context minimum, named on stderr.
  EXPECT_EQ(runPbdam("serve " + d + " --port 0 --workers 2 --gpu-cache-mb 0.001"), 2);
}

TEST(Serve, FramesEqualPbdamRenderByteForByte) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  START_SERVER(server, dir, {"--workers", "2"});
  httplib::Client client = server.client();
  test::TempDir tmp;
  struct Case {
    const char* query;
    const char* camera;
    const char* size;
  };
  // Whole planet, then an oblique close-up (heading, pitch, roll), then a different size on a
  // context that drew another size before, then the first again (now from a warm cache).
  const Case cases[] = {
      {"lat=18.65&lon=226.2&alt=3e6&width=160&height=90", "18.65,226.2,3e6", "160 90"},
      {"lat=18.4&lon=-133.9&alt=60e3&heading=30&pitch=-20&roll=5&width=200&height=120&fov=50"
       "&tolerance=2",
       "18.4,-133.9,60e3,30,-20,5 --fov-deg 50 --tolerance-px 2", "200 120"},
      {"lat=-10&lon=-70&alt=2e6&pitch=-60&width=173&height=97", "-10,-70,2e6,0,-60,0", "173 97"},
      {"lat=18.65&lon=226.2&alt=3e6&width=160&height=90", "18.65,226.2,3e6", "160 90"},
      // The sun of an instant, and one placed over the view's target with an ambient term.
      {"lat=-13.42&lon=-4.706&alt=8e6&width=160&height=90&time=2004-01-03T13:46:31Z",
       "-13.42,-4.706,8e6 --time 2004-01-03T13:46:31Z", "160 90"},
      {"lat=-10&lon=-70&alt=2e6&pitch=-60&width=173&height=97&sun=250,12&ambient=0.1",
       "-10,-70,2e6,0,-60,0 --sun 250,12 --ambient 0.1", "173 97"},
      {"lat=-10&lon=-70&alt=2e6&pitch=-60&width=173&height=97&sun=250,12&atmosphere=off",
       "-10,-70,2e6,0,-60,0 --sun 250,12 --atmosphere off", "173 97"},
      {"lat=-10&lon=-68&alt=10e3&heading=90&pitch=-8&width=160&height=90"
       "&time=2004-01-03T20:00:00Z&exposure=15",
       "-10,-68,10e3,90,-8,0 --time 2004-01-03T20:00:00Z --exposure 15", "160 90"},
  };
  int index = 0;
  for (const Case& c : cases) {
    SCOPED_TRACE(c.query);
    auto res = client.Get(std::string("/frame?") + c.query);
    ASSERT_TRUE(res) << httplib::to_string(res.error());
    ASSERT_EQ(res->status, 200) << res->body;
    EXPECT_EQ(res->get_header_value("Content-Type"), "image/png");
    EXPECT_GT(std::stoi(res->get_header_value("X-Pbdam-Patches")), 0);
    const auto png = tmp / ("render" + std::to_string(index++) + ".png");
    std::string size = c.size;
    size.replace(size.find(' '), 1, " --height ");
    ASSERT_EQ(runPbdam("render " + quoted(dir.string()) + " --camera " + c.camera + " --width " +
                       size + " --out " + quoted(png.string()) + " --quiet"),
              0);
    const std::string expected = test::readFile(png);
    ASSERT_EQ(expected.substr(0, 8), kPng);
    EXPECT_EQ(res->body.size(), expected.size());
    EXPECT_TRUE(res->body == expected) << "server PNG differs from pbdam render's";
  }
  auto jpeg = client.Get("/frame?lat=0&lon=0&alt=4e6&width=64&height=48&format=jpeg&quality=80");
  ASSERT_TRUE(jpeg);
  ASSERT_EQ(jpeg->status, 200) << jpeg->body;
  EXPECT_EQ(jpeg->get_header_value("Content-Type"), "image/jpeg");
  EXPECT_EQ(jpeg->body.substr(0, 3), std::string("\xff\xd8\xff", 3));
}

// pbdam serve --exaggeration F draws every frame at F: pbdam render --exaggeration F's bytes,
// with exaggeration=F or without it; another factor, or a bad one, is a 400 naming the
// parameter (the shared cache holds patches decoded under F); and a bad F does not start.
TEST(Serve, AnExaggeratedServerDrawsPbdamRendersFramesAndNamesOtherFactors) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const std::string d = quoted(dir.string());
  for (const char* bad : {"0", "-1", "nan", "1000"}) {
    const test::CommandRun run =
        capturePbdam("serve " + d + " --port 0 --exaggeration " + std::string(bad));
    EXPECT_EQ(run.exitCode, 2) << bad;
    EXPECT_NE(run.err.find("--exaggeration"), std::string::npos) << run.err;
  }
  START_SERVER(server, dir, {"--workers", "1", "--exaggeration", "5"});
  httplib::Client client = server.client();
  test::TempDir tmp;
  const auto png = tmp / "render.png";
  ASSERT_EQ(runPbdam("render " + d + " --camera 15.4,226.2,160e3,0,-5,0 --exaggeration 5" +
                     " --width 160 --height 90 --out " + quoted(png.string()) + " --quiet"),
            0);
  const std::string expected = test::readFile(png);
  const std::string query = "/frame?lat=15.4&lon=226.2&alt=160e3&pitch=-5&width=160&height=90";
  for (const std::string extra : {"", "&exaggeration=5"}) {
    auto res = client.Get(query + extra);
    ASSERT_TRUE(res) << httplib::to_string(res.error());
    ASSERT_EQ(res->status, 200) << res->body;
    EXPECT_TRUE(res->body == expected) << "server PNG differs from pbdam render's" << extra;
  }
  for (const char* value : {"3", "0", "-1", "nan", "1000", "abc"}) {
    const std::string what = query + "&exaggeration=" + value;
    auto res = client.Get(what);
    expectJsonError(res, what);
    ASSERT_TRUE(res);
    EXPECT_EQ(res->status, 400) << what;
    EXPECT_NE(res->body.find("exaggeration"), std::string::npos) << what << ": " << res->body;
  }
}

// A server started without the atmosphere draws the camera light's and the sun's frames
// without air, as `render --atmosphere off` does, and refuses atmosphere=on; a bad
// --atmosphere is exit code 2.
TEST(Serve, WithoutTheAtmosphereARequestForItIsRefused) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  const std::string d = quoted(dir.string());
  const test::CommandRun bad = capturePbdam("serve " + d + " --port 0 --atmosphere thick");
  EXPECT_EQ(bad.exitCode, 2);
  EXPECT_NE(bad.err.find("--atmosphere 'thick'"), std::string::npos) << bad.err;
  START_SERVER(server, dir, {"--workers", "1", "--atmosphere", "off"});
  httplib::Client client = server.client();
  test::TempDir tmp;
  const auto png = tmp / "render.png";
  ASSERT_EQ(runPbdam("render " + d + " --camera -10,-68,10e3,90,-8,0 --time 2004-01-03T20:00:00Z" +
                     " --atmosphere off --width 160 --height 90 --out " + quoted(png.string()) +
                     " --quiet"),
            0);
  const std::string query =
      "/frame?lat=-10&lon=-68&alt=10e3&heading=90&pitch=-8&width=160&height=90"
      "&time=2004-01-03T20:00:00Z";
  auto res = client.Get(query);
  ASSERT_TRUE(res) << httplib::to_string(res.error());
  ASSERT_EQ(res->status, 200) << res->body;
  EXPECT_TRUE(res->body == test::readFile(png)) << "server PNG differs from pbdam render's";
  const std::string on = query + "&atmosphere=on";
  auto refused = client.Get(on);
  expectJsonError(refused, on);
  ASSERT_TRUE(refused);
  EXPECT_EQ(refused->status, 400);
  EXPECT_NE(refused->body.find("--atmosphere off"), std::string::npos) << refused->body;
}

TEST(Serve, MalformedRequestsGet4xxWithJsonError) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  START_SERVER(server, dir, {"--workers", "1"});
  httplib::Client client = server.client();
  const std::string ok = "lat=0&lon=0&alt=4e6&width=32&height=32";
  const std::vector<std::string> badGets = {
      "/frame",                                                 // nothing
      "/frame?lon=0&alt=4e6",                                   // lat missing
      "/frame?lat=0&lon=0",                                     // alt missing
      "/frame?lat=nan&lon=0&alt=4e6",                           // NaN
      "/frame?lat=91&lon=0&alt=4e6",                            // out of range
      "/frame?lat=0&lon=abc&alt=4e6",                           // not a number
      "/frame?lat=0&lon=0&alt=inf",                             // infinite
      "/frame?lat=0&lon=0&alt=1e400",                           // overflows a double
      "/frame?lat=0&lon=0&alt=-3e6",                            // inside the planet
      "/frame?lat=&lon=0&alt=4e6",                              // empty value
      "/frame?lat=0&lon=0&alt=4e6abc",                          // trailing garbage
      "/frame?" + ok + "&width=5000",                           // beyond 4096
      "/frame?lat=0&lon=0&alt=4e6&width=0",                     // zero
      "/frame?lat=0&lon=0&alt=4e6&height=-5",                   // negative
      "/frame?lat=0&lon=0&alt=4e6&width=12.5",                  // not whole
      "/frame?lat=0&lon=0&alt=4e6&width=99999999999999999999",  // overflows
      "/frame?" + ok + "&fov=0",                                // fov bounds
      "/frame?" + ok + "&fov=179",                              //
      "/frame?" + ok + "&tolerance=0",                          // tolerance bounds
      "/frame?" + ok + "&tolerance=-1",                         //
      "/frame?" + ok + "&pitch=100",                            // pitch bounds
      "/frame?" + ok + "&format=gif",                           // unknown format
      "/frame?" + ok + "&morph=yes",                            // morph is on or off
      "/frame?" + ok + "&quality=80",                           // quality without jpeg
      "/frame?" + ok + "&format=jpeg&quality=0",                // quality bounds
      "/frame?" + ok + "&colour=red",                           // unknown parameter
      "/frame?" + ok + "&time=2024-02-30",                      // no such date
      "/frame?" + ok + "&time=%01%02",                          // not printable
      "/frame?" + ok + "&time=2024-01-01&sun=10,10",            // the sun given twice
      "/frame?" + ok + "&sun=10,95",                            // elevation bounds
      "/frame?" + ok + "&ambient=2",                            // ambient bounds
      "/frame?" + ok + "&atmosphere=thick",                     // auto, on or off
      "/frame?" + ok + "&exposure=0",                           // exposure bounds
      "/frame?" + ok + "&lat=1",                                // repeated
      "/height",                                                // nothing
      "/height?lat=100&lon=0",                                  // out of range
      "/height?lat=0&lon=0&alt=5",                              // unknown parameter
      "/info?verbose=1",                                        // takes none
      "/stats?x",                                               //
      "/nope",                                                  // unknown path
      "/frame/../../etc/passwd",                                // no filesystem
      "/index.html",                                            // only / is the viewer
  };
  for (const std::string& path : badGets) expectJsonError(client.Get(path), "GET " + path);
  EXPECT_EQ(client.Get("/nope")->status, 404);
  EXPECT_EQ(client.Get("/frame?lat=91&lon=0&alt=4e6")->status, 400);

  // Other methods on our paths: 405 with Allow.
  auto post = client.Post("/frame?" + ok, "x", "text/plain");
  expectJsonError(post, "POST /frame");
  EXPECT_EQ(post->status, 405);
  EXPECT_EQ(post->get_header_value("Allow"), "GET, HEAD");
  expectJsonError(client.Delete("/stats"), "DELETE /stats");
  expectJsonError(client.Put("/", "x", "text/plain"), "PUT /");
  expectJsonError(client.Options("/frame"), "OPTIONS /frame");
  expectJsonError(client.Post("/upload", std::string(200000, 'x'), "text/plain"),
                  "POST with a body over the limit");

  // Bytes that are not HTTP, an unknown method, an over-long URI.
  for (const std::string& raw :
       {std::string("GARBAGE\r\n\r\n"), std::string("BREW /frame HTTP/1.1\r\nHost: x\r\n\r\n"),
        "GET /frame?lat=" + std::string(20000, '1') + " HTTP/1.1\r\nHost: x\r\n\r\n"}) {
    const std::string reply = rawExchange(server.port(), raw);
    SCOPED_TRACE(raw.substr(0, 40));
    ASSERT_EQ(reply.substr(0, 9), "HTTP/1.1 ") << reply;
    const int status = std::atoi(reply.c_str() + 9);
    EXPECT_GE(status, 400);
    EXPECT_LT(status, 500);
    EXPECT_NE(reply.find("application/json"), std::string::npos) << reply;
    EXPECT_NE(reply.find("\"message\""), std::string::npos) << reply;
  }

  // Still serving, every refusal counted, nothing drawn.
  auto health = client.Get("/healthz");
  ASSERT_TRUE(health);
  EXPECT_EQ(health->status, 200);
  auto stats = nlohmann::json::parse(client.Get("/stats")->body);
  EXPECT_EQ(stats["render"]["frames"], 0);
  EXPECT_GE(stats["server"]["responses"]["400"].get<int>(), 25);
}

TEST(Serve, InfoHeightStatsHealthzAndViewer) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  START_SERVER(server, dir, {"--workers", "1"});
  httplib::Client client = server.client();
  auto info = client.Get("/info");
  ASSERT_TRUE(info);
  ASSERT_EQ(info->status, 200);
  const auto i = nlohmann::json::parse(info->body);
  EXPECT_EQ(i["planet"], "mars");
  EXPECT_EQ(i["equatorial_radius_m"], 3396190.0);
  EXPECT_GT(i["patches"].get<int>(), 0);
  EXPECT_EQ(i["frame"]["max_side_px"], 4096);

  // /height is `pbdam height --json`'s figure.
  auto height = client.Get("/height?lat=18.4&lon=-133.9");
  ASSERT_TRUE(height);
  ASSERT_EQ(height->status, 200) << height->body;
  const auto h = nlohmann::json::parse(height->body);
  const std::string cliCommand =
      quoted(PBDAM_EXE) + " height " + quoted(dir.string()) + " --at 18.4,-133.9 --json";
  FILE* pipe = ::popen(cliCommand.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::string cliOut;
  std::array<char, 4096> buf{};
  std::size_t n = 0;
  while ((n = std::fread(buf.data(), 1, buf.size(), pipe)) > 0) cliOut.append(buf.data(), n);
  ::pclose(pipe);
  EXPECT_EQ(h["height_m"], nlohmann::json::parse(cliOut)["height_m"]);
  EXPECT_GT(h["height_m"].get<double>(), 15000.0);  // Olympus Mons

  auto frame = client.Get("/frame?lat=0&lon=0&alt=4e6&width=64&height=48");
  ASSERT_TRUE(frame);
  ASSERT_EQ(frame->status, 200);
  auto stats = client.Get("/stats");
  ASSERT_TRUE(stats);
  const auto s = nlohmann::json::parse(stats->body);
  EXPECT_EQ(s["render"]["frames"], 1);
  EXPECT_EQ(s["render"]["contexts"], 1);
  EXPECT_GT(s["cache"]["misses"].get<int>(), 0);
  EXPECT_GT(s["cache"]["resident_bytes"].get<std::int64_t>(), 0);
  EXPECT_EQ(s["queue"]["capacity"], 8);
  EXPECT_GT(s["server"]["rss_bytes"].get<std::int64_t>(), 0);
  // glibc's view of the heap (ASan's allocator bypasses it, so only the fields are checked).
  for (const char* field : {"in_use_bytes", "mapped_blocks_bytes", "free_in_arenas_bytes"}) {
    EXPECT_GE(s["server"]["heap"][field].get<std::int64_t>(), 0) << field;
  }

  auto health = client.Get("/healthz");
  ASSERT_TRUE(health);
  EXPECT_EQ(health->status, 200);
  EXPECT_EQ(nlohmann::json::parse(health->body)["status"], "ok");

  auto page = client.Get("/");
  ASSERT_TRUE(page);
  EXPECT_EQ(page->status, 200);
  EXPECT_EQ(page->get_header_value("Content-Type"), "text/html; charset=utf-8");
  EXPECT_NE(page->body.find("pbdam viewer"), std::string::npos);
  EXPECT_NE(page->body.find("/frame?"), std::string::npos);
}

// GET /los and /viewshed answer as `pbdam query los|viewshed --json` do; the viewshed comes as
// JSON, GeoTIFF (georeferenced, byte-identical to the command's file) or an RGBA PNG, and
// /frame?viewshed= drapes it (computed once: the frames after it are answered from the kept one).
// Bad queries are 400 naming the parameter.
TEST(Serve, LineOfSightAndViewshedQueries) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  START_SERVER(server, dir, {"--workers", "1"});
  httplib::Client client = server.client();
  test::TempDir tmp;
  auto los = client.Get("/los?from=18.65,226.2,10&to=18.65,230,10");
  ASSERT_TRUE(los);
  ASSERT_EQ(los->status, 200) << los->body;
  const auto line = nlohmann::json::parse(los->body);
  EXPECT_FALSE(line["visible"].get<bool>());
  const auto cliLos = capturePbdam("query los '" + dir.string() +
                                   "' --from 18.65,226.2,10 --to 18.65,230,10 --json");
  ASSERT_EQ(cliLos.exitCode, 0) << cliLos.err;
  EXPECT_EQ(line, nlohmann::json::parse(cliLos.out));

  const std::string at = "at=18.0,226.2,3000&radius_m=300000&cell_m=5000";
  auto json = client.Get("/viewshed?" + at);
  ASSERT_TRUE(json);
  ASSERT_EQ(json->status, 200) << json->body;
  const auto figures = nlohmann::json::parse(json->body);
  const std::filesystem::path file = tmp / "cli.tif";
  const auto cli = capturePbdam("query viewshed '" + dir.string() +
                                "' --at 18.0,226.2,3000 --radius-m 300000 --cell-m 5000 --out '" +
                                file.string() + "' --json");
  ASSERT_EQ(cli.exitCode, 0) << cli.err;
  const auto cliFigures = nlohmann::json::parse(cli.out);
  for (const char* key : {"cells", "cells_in_radius", "visible_cells", "visible_area_km2",
                          "farthest_visible", "observer"}) {
    EXPECT_EQ(figures[key], cliFigures[key]) << key;
  }
  auto tiff = client.Get("/viewshed?" + at + "&format=tif");
  ASSERT_TRUE(tiff);
  ASSERT_EQ(tiff->status, 200);
  EXPECT_EQ(tiff->get_header_value("Content-Type"), "image/tiff");
  std::ifstream in(file, std::ios::binary);
  const std::string fromFile{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  EXPECT_EQ(tiff->body, fromFile) << "the same GeoTIFF as pbdam query viewshed writes";
  auto png = client.Get("/viewshed?" + at + "&format=png");
  ASSERT_TRUE(png);
  ASSERT_EQ(png->status, 200);
  EXPECT_EQ(png->get_header_value("Content-Type"), "image/png");
  EXPECT_EQ(png->body.substr(1, 3), "PNG");

  const std::string camera = "/frame?lat=16&lon=-133.8&alt=600e3&pitch=-60&width=160&height=90";
  auto plain = client.Get(camera);
  auto draped = client.Get(camera + "&viewshed=18.0,226.2,3000,300000");
  ASSERT_TRUE(plain && draped);
  ASSERT_EQ(draped->status, 200) << draped->body;
  EXPECT_NE(plain->body, draped->body);
  const auto rendered = tmp / "draped.png";
  const auto render = capturePbdam("render '" + dir.string() +
                                   "' --camera 16,-133.8,600e3,0,-60,0 --width 160 --height 90 "
                                   "--viewshed 18.0,226.2,3000,300000 --out '" +
                                   rendered.string() + "' --quiet");
  ASSERT_EQ(render.exitCode, 0) << render.err;
  std::ifstream renderedIn(rendered, std::ios::binary);
  EXPECT_EQ(draped->body, std::string(std::istreambuf_iterator<char>(renderedIn),
                                      std::istreambuf_iterator<char>()))
      << "the draped frame is pbdam render --viewshed's";
  const auto stats = nlohmann::json::parse(client.Get("/stats")->body)["queries"];
  EXPECT_EQ(stats["sightlines"], 1);
  EXPECT_EQ(stats["viewsheds"], 2);  // the 5 km cells, then the default cells of the frame's
  EXPECT_GE(stats["viewshed_hits"], 2);

  for (const auto& [query, mention] : std::vector<std::pair<std::string, std::string>>{
           {"/los?from=0,0,1", "parameter 'to' is required"},
           {"/los?from=0,0,-1&to=1,1,1", "parameter 'from': the point is underground"},
           {"/los?from=1,1,1&to=1,1,1", "the same point"},
           {"/viewshed?at=0,0", "parameter 'at'"},
           {"/viewshed?at=0,0,-1", "parameter 'at': the observer is underground"},
           {"/viewshed?at=0,0,10&radius_m=0", "parameter 'radius_m' must be > 0"},
           {"/viewshed?at=0,0,10&radius_m=5e6",
            "parameter 'radius_m' 5000000 m is beyond the horizon"},
           {"/viewshed?at=0,0,10&radius_m=5e5&cell_m=300", "the server computes at most 2049"},
           {"/viewshed?at=0,0,10&format=gif", "parameter 'format'"},
           {"/viewshed?at=0,0,10&colour=red", "unknown parameter 'colour'"},
           {"/frame?lat=0&lon=0&alt=1e6&viewshed=1,2", "parameter 'viewshed'"},
           {"/frame?lat=0&lon=0&alt=1e6&viewshed=0,0,-3", "parameter 'viewshed': parameter 'at'"},
       }) {
    auto res = client.Get(query);
    expectJsonError(res, query);
    EXPECT_EQ(res->status, 400) << query;
    EXPECT_NE(res->body.find(mention), std::string::npos) << query << ": " << res->body;
  }
}

}  // namespace
}  // namespace pbdam::tools
