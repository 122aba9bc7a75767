// A test's own copy of a shared test dataset. Tests that evict a dataset from the page cache and
// then watch what comes back use one: tests running beside them read the shared dataset and fault
// its pages back in, so an eviction of the shared copy does not hold.
#pragma once

#include <filesystem>

#include "TestData.h"

namespace pbdam::test {

/// Copies the dataset directory `shared` into `temp` and returns the copy's path.
inline std::filesystem::path privateCopy(const std::filesystem::path& shared, const TempDir& temp) {
  std::filesystem::path dir = temp / shared.filename();
  std::filesystem::copy(shared, dir);
  return dir;
}

}  // namespace pbdam::test
