// What the `pbdam serve` tests (TestServe.cpp, TestServeOperations.cpp) share: the server as a
// child process on a free loopback port, and `pbdam` run beside it for the frames it must equal.
#pragma once

#include <gtest/gtest.h>
#include <httplib.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

extern char** environ;

namespace pbdam::tools::serve_test {

/// Sanitizer builds start lavapipe and the validation layer slowly.
inline constexpr int kStartSeconds = 180;
inline constexpr time_t kRequestSeconds = 120;

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
      if (!waitExit(std::chrono::seconds(60))) {
        ::kill(pid_, SIGKILL);
        waitExit(std::chrono::seconds(10));
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

/// 'text' for a shell command line, built step by step: GCC 12 -O3 warns (-Wrestrict) on
/// "'" + s + "'".
inline std::string quoted(const std::string& text) {
  std::string q = "'";
  q += text;
  q += '\'';
  return q;
}

/// Runs `pbdam ARGS` and returns its exit code.
inline int runPbdam(const std::string& args) {
  const std::string command = quoted(PBDAM_EXE) + " " + args + " >/dev/null 2>&1";
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

/// The signature that starts every PNG file.
inline constexpr std::string_view kPng("\x89PNG\r\n\x1a\n", 8);

}  // namespace pbdam::tools::serve_test

/// Starts `pbdam serve DATASET --port 0 ARGS...` as `var`; the test fails unless it listens.
#define START_SERVER(var, dataset, ...)                                \
  ::pbdam::tools::serve_test::ServerProcess var(dataset, __VA_ARGS__); \
  ASSERT_GT(var.port(), 0) << "server did not start; stdout: " << var.output()
