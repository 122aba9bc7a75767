// `pbdam serve` as a client sees it: the server runs as its own process on a free loopback port
// (--port 0; the start-up line names it) and is driven with httplib's client. Frames equal
// `pbdam render`'s PNG for the same camera byte for byte; malformed requests get a 4xx with a
// JSON body; a burst beyond the queue gets 503 + Retry-After and the server survives; SIGTERM
// lets in-flight frames finish and the process exits 0; face files truncated under the server
// fail frames with a 5xx JSON error while it goes on serving, and a reload serves a dataset put
// in their place.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <httplib.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "TestData.h"

extern char** environ;

namespace pbdam::tools {
namespace {

using namespace std::chrono_literals;

/// Sanitizer builds start lavapipe and the validation layer slowly.
constexpr int kStartSeconds = 180;
constexpr time_t kRequestSeconds = 120;

/// `pbdam serve DIR --port 0 ARGS...` as a child process; stdout is a pipe the start-up line is
/// read from. The destructor stops a server still running (SIGTERM, then SIGKILL).
class ServerProcess final {
 public:
  ServerProcess(const std::filesystem::path& dataset, const std::vector<std::string>& args) {
    std::vector<std::string> argv = {PBDAM_EXE, "serve", dataset.string(), "--port", "0"};
    argv.insert(argv.end(), args.begin(), args.end());
    std::vector<char*> cargv;
    cargv.reserve(argv.size() + 1);
    for (std::string& a : argv) cargv.push_back(a.data());
    cargv.push_back(nullptr);
    int fds[2];
    if (::pipe(fds) != 0) return;
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, fds[1], STDOUT_FILENO);
    posix_spawn_file_actions_addclose(&actions, fds[0]);
    posix_spawn_file_actions_addclose(&actions, fds[1]);
    const int spawned = ::posix_spawn(&pid_, PBDAM_EXE, &actions, nullptr, cargv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    ::close(fds[1]);
    out_ = fds[0];
    if (spawned != 0) {
      pid_ = -1;
      return;
    }
    // The start-up line: "pbdam serve: http://127.0.0.1:PORT/ (...)".
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(kStartSeconds);
    while (std::chrono::steady_clock::now() < until && output_.find('\n') == std::string::npos) {
      if (!readSome(500)) {
        if (exited()) break;
      }
    }
    const std::string marker = "http://127.0.0.1:";
    const std::size_t at = output_.find(marker);
    if (at != std::string::npos) port_ = std::atoi(output_.c_str() + at + marker.size());
  }
  /// A server still running is stopped with SIGTERM, and must then exit 0 (the graceful
  /// shutdown): a server that does not — under the sanitizers, one that reported an error,
  /// on its way down too (exit code 66) — fails the test.
  ~ServerProcess() {
    if (pid_ > 0 && !exitStatus_) {
      ::kill(pid_, SIGTERM);
      if (!waitExit(60s)) {
        ::kill(pid_, SIGKILL);
        waitExit(10s);
        ADD_FAILURE() << "the server did not exit within 60 s of SIGTERM";
      } else if (!WIFEXITED(*exitStatus_) || WEXITSTATUS(*exitStatus_) != 0) {
        ADD_FAILURE() << "the server did not exit 0 on SIGTERM (wait status " << *exitStatus_
                      << "; a sanitizer report exits 66)";
      }
    }
    if (out_ >= 0) ::close(out_);
  }
  ServerProcess(const ServerProcess&) = delete;
  ServerProcess& operator=(const ServerProcess&) = delete;

  int port() const { return port_; }
  pid_t pid() const { return pid_; }
  const std::string& output() const { return output_; }

  httplib::Client client() const {
    httplib::Client c("127.0.0.1", port_);
    c.set_read_timeout(kRequestSeconds, 0);
    c.set_connection_timeout(10, 0);
    return c;
  }

  /// Waits for the process to exit (reading its stdout meanwhile); true when it did.
  bool waitExit(std::chrono::seconds limit) {
    const auto until = std::chrono::steady_clock::now() + limit;
    while (!exited()) {
      if (std::chrono::steady_clock::now() > until) return false;
      readSome(100);
    }
    while (readSome(0)) {
    }
    return true;
  }
  /// The exit status once the process has exited.
  std::optional<int> exitStatus() const { return exitStatus_; }

 private:
  bool exited() {
    if (exitStatus_) return true;
    int status = 0;
    if (pid_ > 0 && ::waitpid(pid_, &status, WNOHANG) == pid_) exitStatus_ = status;
    return exitStatus_.has_value();
  }
  bool readSome(int timeoutMs) {
    pollfd p{out_, POLLIN, 0};
    if (::poll(&p, 1, timeoutMs) <= 0) return false;
    std::array<char, 4096> buf{};
    const ssize_t n = ::read(out_, buf.data(), buf.size());
    if (n <= 0) return false;
    output_.append(buf.data(), static_cast<std::size_t>(n));
    return true;
  }

  pid_t pid_ = -1;
  int out_ = -1;
  int port_ = 0;
  std::string output_;
  std::optional<int> exitStatus_;
};

#define START_SERVER(var, dataset, ...)    \
  ServerProcess var(dataset, __VA_ARGS__); \
  ASSERT_GT(var.port(), 0) << "server did not start; stdout: " << var.output()

/// 'text' for a shell command line, built step by step: GCC 12 -O3 warns (-Wrestrict) on
/// "'" + s + "'".
std::string quoted(const std::string& text) {
  std::string q = "'";
  q += text;
  q += '\'';
  return q;
}

/// Runs `pbdam ARGS` and returns its exit code.
int runPbdam(const std::string& args) {
  const std::string command = quoted(PBDAM_EXE) + " " + args + " >/dev/null 2>&1";
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

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

constexpr std::string_view kPng("\x89PNG\r\n\x1a\n", 8);

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
