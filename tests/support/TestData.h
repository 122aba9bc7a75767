// Where tests find the real elevation data of ../shared/data and the built-in default data.
// Missing data fails the test under CI=true and skips it (with the reason) elsewhere.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

namespace pbdam::test {

/// The data directory: $PBDAM_DATA_DIR if set, else the configured default (../shared/data).
std::filesystem::path dataDir();

/// The message explaining that `path` is missing, or an empty string when it is a readable file.
std::string missingFileMessage(const std::filesystem::path& path);

/// True when running under CI (CI=true): missing data then fails instead of skipping.
bool runningInCi();

/// A fresh, empty temporary directory unique to the running test; removed by the caller's
/// TempDir owner.
class TempDir final {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const noexcept { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

/// What a shell command printed, and how it ended.
struct CommandRun final {
  int exitCode = -1;  ///< -1 when it did not exit normally or could not be started
  std::string out;
  std::string err;
};

/// Runs `command` through /bin/sh, capturing stdout (a pipe) and stderr (a temporary file).
CommandRun runCommand(const std::string& command);

/// The bytes of a file; empty when it cannot be read.
std::string readFile(const std::filesystem::path& path);

}  // namespace pbdam::test

/// Declares `var` as the path of a required data file; when it is missing, fails the test
/// under CI and skips it elsewhere, naming the file either way.
#define PBDAM_REQUIRE_DATA(var, file)                                                \
  const std::filesystem::path var = (file);                                          \
  if (const std::string pbdamMissing_##var = ::pbdam::test::missingFileMessage(var); \
      !pbdamMissing_##var.empty()) {                                                 \
    if (::pbdam::test::runningInCi()) {                                              \
      FAIL() << pbdamMissing_##var;                                                  \
    }                                                                                \
    GTEST_SKIP() << pbdamMissing_##var;                                              \
  }                                                                                  \
  static_assert(true)

/// ETOPO5 from Debian's ferret-datasets (the built-in default Earth data).
#define PBDAM_ETOPO5_PATH std::filesystem::path("/usr/share/ferret-vis/data/etopo5.cdf")

namespace pbdam::test {
/// The directory of a test dataset built by the `datasets` fixture (tests/CMakeLists.txt):
/// "mola" (MOLA 4 px/deg), "earth" (ETOPO5, 512 cells per face side) or "luxembourg" (ETOPO5
/// with the Luxembourg GeoTIFF as an inset).
std::filesystem::path testDatasetDir(const std::string& name);
}  // namespace pbdam::test

/// Declares `var` as the directory of test dataset `name`; when it was not built (its input data
/// is missing), fails under CI and skips elsewhere.
#define PBDAM_REQUIRE_DATASET(var, name)                                                      \
  const std::filesystem::path var = ::pbdam::test::testDatasetDir(name);                      \
  if (!std::filesystem::exists(var / "manifest.json")) {                                      \
    const std::string pbdamWhy_##var =                                                        \
        "test dataset " + var.string() + " was not built (see the build_test_datasets test)"; \
    if (::pbdam::test::runningInCi()) {                                                       \
      FAIL() << pbdamWhy_##var;                                                               \
    }                                                                                         \
    GTEST_SKIP() << pbdamWhy_##var;                                                           \
  }                                                                                           \
  static_assert(true)
