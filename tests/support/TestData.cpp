// Test data location and temporary directories (TestData.h).
#include "TestData.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <random>
#include <string_view>

namespace pbdam::test {

std::filesystem::path dataDir() {
  if (const char* env = std::getenv("PBDAM_DATA_DIR"); env != nullptr && *env != '\0') {
    return env;
  }
  return PBDAM_DEFAULT_DATA_DIR;
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

}  // namespace pbdam::test
