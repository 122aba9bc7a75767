// `pbdam serve` in operation: render contexts sharing one GPU cache under concurrent clients,
// frames in flight, a burst beyond the queue (503 + Retry-After, and the server survives), a
// missed deadline, SIGTERM letting in-flight frames finish (exit 0), and face files truncated
// under the server (5xx JSON errors while it goes on serving) until a reload serves a dataset
// put in their place. The server runs as its own process (ServeTestSupport.h).
#include <gtest/gtest.h>
#include <httplib.h>
#include <signal.h>
#include <sys/wait.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "ServeTestSupport.h"
#include "TestData.h"

namespace pbdam::tools {
namespace {

using namespace std::chrono_literals;
using namespace serve_test;

TEST(Serve, RenderContextsShareOneGpuCache) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  START_SERVER(server, dir, {"--workers", "2", "--queue", "8"});
  const std::string query = "/frame?lat=-20&lon=300&alt=2e6&pitch=-70&width=320&height=240";
  httplib::Client warm = server.client();
  auto first = warm.Get(query);
  ASSERT_TRUE(first);
  ASSERT_EQ(first->status, 200) << first->body;
  EXPECT_GT(std::stoi(first->get_header_value("X-Pbdam-Cache-Misses")), 0);
  const auto residentAfterFirst =
      nlohmann::json::parse(warm.Get("/stats")->body)["cache"]["resident_bytes"]
          .get<std::int64_t>();

  // The same frame from several clients at once: both contexts draw some of them, and every
  // one — whichever context draws it — finds everything resident.
  constexpr int kClients = 6;
  std::vector<std::string> misses(kClients), contexts(kClients), bodies(kClients);
  std::vector<int> statuses(kClients, -1);
  std::atomic<int> ready{0};
  std::vector<std::thread> clients;
  clients.reserve(kClients);
  for (int c = 0; c < kClients; ++c) {
    clients.emplace_back([&, c] {
      httplib::Client client = server.client();
      ++ready;
      while (ready.load() < kClients) std::this_thread::yield();
      auto res = client.Get(query);
      if (!res) return;
      const auto i = static_cast<std::size_t>(c);
      statuses[i] = res->status;
      misses[i] = res->get_header_value("X-Pbdam-Cache-Misses");
      contexts[i] = res->get_header_value("X-Pbdam-Context");
      bodies[i] = res->body;
    });
  }
  for (std::thread& t : clients) t.join();
  std::map<std::string, int> drawnBy;
  for (std::size_t i = 0; i < kClients; ++i) {
    ASSERT_EQ(statuses[i], 200) << "client " << i;
    EXPECT_EQ(misses[i], "0") << "client " << i << ", context " << contexts[i];
    EXPECT_TRUE(bodies[i] == first->body) << "client " << i << " got another image";
    ++drawnBy[contexts[i]];
  }
  EXPECT_EQ(drawnBy.size(), 2u) << "both contexts were meant to draw";

  const auto s = nlohmann::json::parse(warm.Get("/stats")->body);
  EXPECT_EQ(s["cache"]["shared_by_contexts"], 2);
  EXPECT_EQ(s["cache"]["resident_bytes"].get<std::int64_t>(), residentAfterFirst);
  EXPECT_EQ(s["cache"]["pinned_bytes"], 0);
  const int entries = std::stoi(first->get_header_value("X-Pbdam-Cache-Misses"));
  EXPECT_EQ(s["cache"]["misses"].get<int>(), entries);
  EXPECT_EQ(s["cache"]["hits"].get<int>(), kClients * entries);
}

// One context with three frames in flight and a queue of requests for different views: it
// records the next while the device draws, and every answer is the frame that view gets alone.
TEST(Serve, AContextWithFramesInFlightAnswersEachRequestWithItsOwnFrame) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  START_SERVER(server, dir, {"--workers", "1", "--queue", "16", "--frames-in-flight", "3"});
  constexpr int kClients = 8;
  const auto query = [](int c) {
    return "/frame?lat=" + std::to_string(-40 + 10 * c) + "&lon=" + std::to_string(20 * c) +
           "&alt=2e6&pitch=-60&width=160&height=120";
  };
  std::vector<std::string> bodies(kClients);
  std::vector<int> statuses(kClients, -1);
  std::atomic<int> ready{0};
  std::vector<std::thread> clients;
  clients.reserve(kClients);
  for (int c = 0; c < kClients; ++c) {
    clients.emplace_back([&, c] {
      httplib::Client client = server.client();
      ++ready;
      while (ready.load() < kClients) std::this_thread::yield();
      auto res = client.Get(query(c));
      if (!res) return;
      statuses[static_cast<std::size_t>(c)] = res->status;
      bodies[static_cast<std::size_t>(c)] = res->body;
    });
  }
  for (std::thread& t : clients) t.join();
  httplib::Client alone = server.client();
  for (int c = 0; c < kClients; ++c) {
    const auto i = static_cast<std::size_t>(c);
    ASSERT_EQ(statuses[i], 200) << "client " << c << ": " << bodies[i];
    auto again = alone.Get(query(c));  // one at a time: nothing else in flight
    ASSERT_TRUE(again);
    ASSERT_EQ(again->status, 200) << again->body;
    EXPECT_TRUE(bodies[i] == again->body) << "client " << c << " got another view's frame";
  }
  const auto s = nlohmann::json::parse(alone.Get("/stats")->body);
  EXPECT_EQ(s["render"]["frames_in_flight"], 3);
  EXPECT_EQ(s["render"]["frames"], 2 * kClients);
  EXPECT_EQ(s["cache"]["pinned_bytes"], 0);
}

TEST(Serve, BurstBeyondTheQueueGets503WithRetryAfter) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  START_SERVER(server, dir, {"--workers", "1", "--queue", "1"});
  constexpr int kClients = 12;
  std::vector<int> statuses(kClients, -1);
  std::vector<std::string> retryAfter(kClients);
  std::atomic<int> ready{0};
  std::vector<std::thread> clients;
  clients.reserve(kClients);
  for (int c = 0; c < kClients; ++c) {
    clients.emplace_back([&, c] {
      httplib::Client client = server.client();
      ++ready;
      while (ready.load() < kClients) std::this_thread::yield();
      // Distinct cameras, large enough that one frame outlasts the burst.
      auto res = client.Get("/frame?lat=" + std::to_string(c) +
                            "&lon=20&alt=3e6&width=1024&height=768&tolerance=1");
      if (!res) return;
      statuses[static_cast<std::size_t>(c)] = res->status;
      retryAfter[static_cast<std::size_t>(c)] = res->get_header_value("Retry-After");
    });
  }
  for (std::thread& t : clients) t.join();
  int ok = 0, refused = 0;
  for (int c = 0; c < kClients; ++c) {
    const auto i = static_cast<std::size_t>(c);
    if (statuses[i] == 200) ++ok;
    if (statuses[i] == 503) {
      ++refused;
      EXPECT_GE(std::atoi(retryAfter[i].c_str()), 1) << "503 without Retry-After";
    }
    EXPECT_TRUE(statuses[i] == 200 || statuses[i] == 503) << "client " << c << ": " << statuses[i];
  }
  EXPECT_GE(ok, 1);
  EXPECT_GE(refused, 1);
  EXPECT_LE(ok, kClients - 1);

  // The server is alive and says what happened.
  httplib::Client client = server.client();
  auto stats = client.Get("/stats");
  ASSERT_TRUE(stats);
  const auto s = nlohmann::json::parse(stats->body);
  EXPECT_EQ(s["queue"]["rejected_full"].get<int>() + s["queue"]["expired"].get<int>(), refused);
  EXPECT_LE(s["queue"]["peak_queued"].get<int>(), 2);  // one idle context + a queue of one
  auto frame = client.Get("/frame?lat=0&lon=0&alt=4e6&width=32&height=32");
  ASSERT_TRUE(frame);
  EXPECT_EQ(frame->status, 200);
}

TEST(Serve, AFrameNotDrawnBeforeItsDeadlineIs503) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  START_SERVER(server, dir, {"--workers", "1", "--deadline-s", "0.02"});
  httplib::Client client = server.client();
  // Far more than 20 ms of drawing on any CPU: 4096x4096 at half a pixel of tolerance.
  auto res = client.Get("/frame?lat=0&lon=-70&alt=2e6&width=4096&height=4096&tolerance=0.5");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 503) << res->body;
  EXPECT_GE(std::atoi(res->get_header_value("Retry-After").c_str()), 1);
  EXPECT_NE(res->body.find("deadline"), std::string::npos) << res->body;
  // The context finishes that frame and goes on; the server still answers.
  auto health = client.Get("/healthz");
  ASSERT_TRUE(health);
  EXPECT_EQ(health->status, 200);
  const auto s = nlohmann::json::parse(client.Get("/stats")->body);
  EXPECT_EQ(s["queue"]["expired"], 1);
}

TEST(Serve, SigtermFinishesInFlightFramesAndExitsZero) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  // A deadline far beyond any frame: on a loaded machine the queued frame could otherwise miss
  // the default 10 s and be refused with 503, which is not what this test is about.
  START_SERVER(server, dir, {"--workers", "1", "--queue", "4", "--deadline-s", "600"});
  constexpr int kClients = 2;
  std::vector<int> statuses(kClients, -1);
  std::vector<std::string> bodies(kClients);
  std::vector<std::thread> clients;
  clients.reserve(kClients);
  for (int c = 0; c < kClients; ++c) {
    clients.emplace_back([&, c] {
      httplib::Client client = server.client();
      auto res = client.Get("/frame?lat=" + std::to_string(10 * c) +
                            "&lon=-70&alt=2e6&width=1280&height=960&tolerance=1");
      if (!res) return;
      statuses[static_cast<std::size_t>(c)] = res->status;
      bodies[static_cast<std::size_t>(c)] = res->body;
    });
  }
  // Wait until both are admitted and at least one is still queued or drawing, then SIGTERM.
  httplib::Client watcher = server.client();
  bool admitted = false;
  for (int i = 0; i < 4000 && !admitted; ++i) {
    auto stats = watcher.Get("/stats");
    if (stats && stats->status == 200) {
      const auto s = nlohmann::json::parse(stats->body);
      const int inFlight = s["queue"]["rendering"].get<int>() + s["queue"]["queued"].get<int>();
      admitted = inFlight >= 1 && inFlight + s["render"]["frames"].get<int>() >= kClients;
    }
    if (!admitted) std::this_thread::sleep_for(5ms);
  }
  ASSERT_TRUE(admitted);
  ASSERT_EQ(::kill(server.pid(), SIGTERM), 0);
  for (std::thread& t : clients) t.join();
  for (int c = 0; c < kClients; ++c) {
    const auto i = static_cast<std::size_t>(c);
    EXPECT_EQ(statuses[i], 200) << "client " << c;
    EXPECT_EQ(bodies[i].substr(0, 8), kPng) << "client " << c;
  }
  ASSERT_TRUE(server.waitExit(120s));
  ASSERT_TRUE(server.exitStatus().has_value());
  EXPECT_TRUE(WIFEXITED(*server.exitStatus())) << "killed by a signal";
  EXPECT_EQ(WEXITSTATUS(*server.exitStatus()), 0);
  EXPECT_NE(server.output().find("stopped (SIGTERM)"), std::string::npos) << server.output();
  // And nothing listens any more.
  httplib::Client after = server.client();
  after.set_connection_timeout(2, 0);
  EXPECT_FALSE(after.Get("/healthz"));
}

/// The JSON body of a response, or a null value when it is not JSON.
nlohmann::json jsonOf(const httplib::Result& res) {
  return nlohmann::json::parse(res->body, nullptr, false);
}

// The operator's story: the served dataset's face files are truncated in place (a failing disk,
// a half-finished copy). The server stays up, fails the frames it cannot draw with a 5xx JSON
// error naming the file and offset, and /healthz says why it is degraded. A reload of the broken
// directory is refused and keeps what is served; once a different dataset is put in place, a
// reload (POST /admin/reload, then SIGHUP) serves it, frame for frame equal to `pbdam render`.
TEST(Serve, SurvivesTruncatedFacesAndReloadsADatasetPutInPlace) {
  PBDAM_REQUIRE_DATASET(mola, "mola");
  PBDAM_REQUIRE_DATASET(earth, "earth");
  test::TempDir tmp;
  const std::filesystem::path served = tmp / "served";
  std::filesystem::copy(mola, served);
  START_SERVER(server, served, {"--workers", "2"});
  httplib::Client client = server.client();
  auto health = client.Get("/healthz");
  ASSERT_TRUE(health);
  EXPECT_EQ(health->status, 200) << health->body;
  EXPECT_EQ(jsonOf(health)["status"], "ok");

  for (int f = 0; f < 6; ++f) {
    std::filesystem::resize_file(served / ("face" + std::to_string(f) + ".pbdam"), 4096);
  }
  for (const char* query : {"lat=18.65&lon=226.2&alt=3e6&width=160&height=90",
                            "lat=-10&lon=-70&alt=2e6&pitch=-60&width=173&height=97"}) {
    SCOPED_TRACE(query);
    auto res = client.Get(std::string("/frame?") + query);
    ASSERT_TRUE(res) << "no answer: the server died (" << httplib::to_string(res.error()) << ")";
    EXPECT_GE(res->status, 500);
    EXPECT_LT(res->status, 600);
    EXPECT_EQ(res->get_header_value("Content-Type"), "application/json");
    const std::string message = jsonOf(res).value("message", std::string());
    EXPECT_NE(message.find(".pbdam"), std::string::npos) << res->body;
    EXPECT_NE(message.find("offset"), std::string::npos) << res->body;
  }
  auto height = client.Get("/height?lat=18.4&lon=-133.9");
  ASSERT_TRUE(height);
  EXPECT_EQ(height->status, 500) << height->body;
  health = client.Get("/healthz");
  ASSERT_TRUE(health);
  EXPECT_EQ(health->status, 503);
  const auto h = jsonOf(health);
  EXPECT_EQ(h["status"], "degraded") << health->body;
  ASSERT_TRUE(h.contains("reasons")) << health->body;
  EXPECT_NE(h["reasons"].dump().find("truncated"), std::string::npos) << health->body;

  // Reloading the broken directory is refused; the old mapping goes on being served.
  auto refused = client.Post("/admin/reload");
  ASSERT_TRUE(refused);
  EXPECT_EQ(refused->status, 422) << refused->body;
  EXPECT_NE(jsonOf(refused).value("message", std::string()).find("still serving"),
            std::string::npos)
      << refused->body;
  auto info = client.Get("/info");
  ASSERT_TRUE(info);
  EXPECT_EQ(jsonOf(info)["planet"], "mars");

  // A different dataset put in place (manifest last, as a build writes it), then reloaded.
  for (const auto& entry : std::filesystem::directory_iterator(served)) {
    std::filesystem::remove(entry.path());
  }
  for (const auto& entry : std::filesystem::directory_iterator(earth)) {
    if (entry.path().filename() != "manifest.json") {
      std::filesystem::copy(entry.path(), served / entry.path().filename());
    }
  }
  std::filesystem::copy(earth / "manifest.json", served / "manifest.json");
  auto reloaded = client.Post("/admin/reload");
  ASSERT_TRUE(reloaded);
  ASSERT_EQ(reloaded->status, 200) << reloaded->body;
  EXPECT_EQ(jsonOf(reloaded)["generation"], 2);
  health = client.Get("/healthz");
  ASSERT_TRUE(health);
  EXPECT_EQ(health->status, 200) << health->body;
  EXPECT_EQ(jsonOf(health)["status"], "ok");
  info = client.Get("/info");
  ASSERT_TRUE(info);
  EXPECT_EQ(jsonOf(info)["planet"], "earth");
  int index = 0;
  for (const auto& [query, camera] :
       {std::pair<const char*, const char*>{"lat=45&lon=7&alt=3e6&width=160&height=90",
                                            "45,7,3e6 --width 160 --height 90"},
        std::pair<const char*, const char*>{"lat=-10&lon=-70&alt=2e6&pitch=-60&width=173&height=97",
                                            "-10,-70,2e6,0,-60,0 --width 173 --height 97"}}) {
    SCOPED_TRACE(query);
    auto res = client.Get(std::string("/frame?") + query);
    ASSERT_TRUE(res);
    ASSERT_EQ(res->status, 200) << res->body;
    const auto png = tmp / ("render" + std::to_string(index++) + ".png");
    ASSERT_EQ(runPbdam("render " + quoted(earth.string()) + " --camera " + camera + " --out " +
                       quoted(png.string()) + " --quiet"),
              0);
    const std::string expected = test::readFile(png);
    ASSERT_EQ(expected.substr(0, 8), kPng);
    EXPECT_TRUE(res->body == expected) << "served PNG differs from pbdam render's";
  }

  // SIGHUP reloads too (the same dataset again: a new generation, a fresh cache).
  ASSERT_EQ(::kill(server.pid(), SIGHUP), 0);
  int generation = 0;
  for (int i = 0; i < 600 && generation < 3; ++i) {
    auto stats = client.Get("/stats");
    if (stats && stats->status == 200) generation = jsonOf(stats)["dataset"]["generation"];
    if (generation < 3) std::this_thread::sleep_for(100ms);
  }
  EXPECT_EQ(generation, 3);
  auto after = client.Get("/frame?lat=45&lon=7&alt=3e6&width=160&height=90");
  ASSERT_TRUE(after);
  EXPECT_EQ(after->status, 200);
  EXPECT_EQ(jsonOf(client.Get("/stats"))["cache"]["hits"], 0) << "the new cache starts empty";
}

TEST(Serve, AdminReloadIsPostOnly) {
  PBDAM_REQUIRE_DATASET(dir, "mola");
  START_SERVER(server, dir, {"--workers", "1"});
  httplib::Client client = server.client();
  auto get = client.Get("/admin/reload");
  ASSERT_TRUE(get);
  EXPECT_EQ(get->status, 405);
  EXPECT_EQ(get->get_header_value("Allow"), "POST");
  auto withParams = client.Post("/admin/reload?now=1");
  ASSERT_TRUE(withParams);
  EXPECT_EQ(withParams->status, 400);
}

}  // namespace
}  // namespace pbdam::tools
