// What the `pbdam serve` drivers share (bench_serve.cpp, serve_soak.cpp): starting the server on
// a free loopback port, reading its process's memory and descriptors from /proc, percentiles,
// and raw socket exchanges for requests httplib's client will not send.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

extern char** environ;

namespace pbdam::bench {

/// A started `pbdam serve`: pid −1 when it did not start (spawned: whether it ran at all).
struct Server {
  bool spawned = false;
  pid_t pid = -1;
  int port = 0;
  std::string startLine;
};

/// Starts `pbdam serve DATASET --port 0 EXTRA...`; its start-up line names the port. Waits up
/// to 120 s for it.
inline Server startServer(const std::string& pbdam, const std::string& dataset,
                          const std::vector<std::string>& extra) {
  std::vector<std::string> serverArgs = {pbdam, "serve", dataset, "--port", "0"};
  serverArgs.insert(serverArgs.end(), extra.begin(), extra.end());
  std::vector<char*> cargs;
  cargs.reserve(serverArgs.size() + 1);
  for (std::string& s : serverArgs) cargs.push_back(s.data());
  cargs.push_back(nullptr);
  int fds[2];
  if (::pipe(fds) != 0) return Server{};
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, fds[1], STDOUT_FILENO);
  posix_spawn_file_actions_addclose(&actions, fds[0]);
  pid_t server = -1;
  if (::posix_spawn(&server, pbdam.c_str(), &actions, nullptr, cargs.data(), environ) != 0) {
    return Server{};
  }
  posix_spawn_file_actions_destroy(&actions);
  ::close(fds[1]);
  std::string startLine;
  int port = 0;
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (port == 0 && std::chrono::steady_clock::now() < until) {
    pollfd p{fds[0], POLLIN, 0};
    if (::poll(&p, 1, 500) <= 0) continue;
    std::array<char, 1024> buf{};
    const ssize_t n = ::read(fds[0], buf.data(), buf.size());
    if (n <= 0) break;
    startLine.append(buf.data(), static_cast<std::size_t>(n));
    const std::size_t at = startLine.find("127.0.0.1:");
    if (at != std::string::npos && startLine.find('\n') != std::string::npos) {
      port = std::atoi(startLine.c_str() + at + 10);
    }
  }
  // The read end stays open: the server's shutdown line must not meet a closed pipe (SIGPIPE).
  if (port == 0) {
    ::kill(server, SIGKILL);
    ::waitpid(server, nullptr, 0);
    std::fprintf(stderr, "the server did not start: %s\n", startLine.c_str());
    server = -1;
  }
  return Server{true, server, port, startLine};
}

/// A field of /proc/PID/status in MiB ("VmRSS:", "RssAnon:"), 0 when absent.
inline double procStatusMiB(pid_t pid, const std::string& field) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(status, line);) {
    if (line.rfind(field, 0) == 0) return std::atof(line.c_str() + field.size()) / 1024.0;  // kB
  }
  return 0.0;
}

inline double rssMiB(pid_t pid) { return procStatusMiB(pid, "VmRSS:"); }

/// The process's open file descriptors (entries of /proc/PID/fd), −1 when unreadable.
inline int openFds(pid_t pid) {
  std::error_code ec;
  int n = 0;
  for (std::filesystem::directory_iterator it("/proc/" + std::to_string(pid) + "/fd", ec), end;
       !ec && it != end; it.increment(ec)) {
    ++n;
  }
  return ec ? -1 : n;
}

inline double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const auto k = static_cast<std::size_t>(std::ceil(p * static_cast<double>(v.size()))) - 1;
  return v[std::min(k, v.size() - 1)];
}

/// A connected loopback TCP socket to `port`, or −1.
inline int connectLoopback(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return -1;
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

/// Sends `raw` on a fresh connection and returns the HTTP status of the reply (0 when none
/// came within `timeoutMs`).
inline int rawStatus(int port, const std::string& raw, int timeoutMs = 5000) {
  const int fd = connectLoopback(port);
  if (fd < 0) return 0;
  (void)::send(fd, raw.data(), raw.size(), MSG_NOSIGNAL);
  std::string reply;
  const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeoutMs);
  while (std::chrono::steady_clock::now() < until && reply.find("\r\n") == std::string::npos) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 100) <= 0) continue;
    std::array<char, 512> buf{};
    const ssize_t n = ::recv(fd, buf.data(), buf.size(), 0);
    if (n <= 0) break;
    reply.append(buf.data(), static_cast<std::size_t>(n));
  }
  ::close(fd);
  const std::size_t space = reply.find(' ');
  return reply.rfind("HTTP/", 0) == 0 && space != std::string::npos
             ? std::atoi(reply.c_str() + space + 1)
             : 0;
}

}  // namespace pbdam::bench
