// Test data location and temporary directories (TestData.h).
#include "TestData.h"

#include <gtest/gtest.h>

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <random>
#include <string_view>

namespace pbdam::test {

std::filesystem::path dataDir() {
  if (const char* env = std::getenv("PBDAM_DATA_DIR"); env != nullptr && *env != '\0') {
    return env;
  }
  return PBDAM_DEFAULT_DATA_DIR;
}

std::filesystem::path testDatasetDir(const std::string& name) {
  return std::filesystem::path(PBDAM_TEST_DATASET_DIR) / name;
}

std::string missingFileMessage(const std::filesystem::path& path) {
  std::error_code ec;
  if (std::filesystem::is_regular_file(path, ec)) return {};
  return "test data not found: " + path.string() +
         " (set PBDAM_DATA_DIR to the directory holding shared/data, or run scripts/setup.sh "
         "for the Debian-packaged default data)";
}

bool runningInCi() {
  const char* ci = std::getenv("CI");
  return ci != nullptr && std::string_view(ci) == "true";
}

TempDir::TempDir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string name = info != nullptr ? std::string(info->test_suite_name()) + "." + info->name()
                                     : std::string("pbdam");
  std::random_device rd;
  path_ =
      std::filesystem::temp_directory_path() / ("pbdam-test-" + name + "-" + std::to_string(rd()));
  std::filesystem::create_directories(path_);
}

TempDir::~TempDir() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

CommandRun runCommand(const std::string& command) {
  const TempDir dir;
  const std::string errFile = (dir / "stderr.txt").string();
  CommandRun run;
  FILE* pipe = ::popen((command + " 2>'" + errFile + "'").c_str(), "r");
  if (pipe == nullptr) return run;
  std::array<char, 4096> buf{};
  std::size_t n = 0;
  while ((n = std::fread(buf.data(), 1, buf.size(), pipe)) > 0) run.out.append(buf.data(), n);
  const int status = ::pclose(pipe);
  run.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream in(errFile);
  run.err.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  return run;
}

std::string readFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

}  // namespace pbdam::test
