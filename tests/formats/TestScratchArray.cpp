// Scratch arrays: in memory without a directory, in an unnamed scratch file with one (memory
// again where none can be made), and elements that outlive the array through its shared owner.
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <numeric>

#include "TestData.h"
#include "pbdam/formats/ScratchArray.h"

namespace pbdam::formats {
namespace {

TEST(ScratchArray, WithoutADirectoryIsInMemory) {
  auto array = ScratchArray<std::uint16_t>::allocate(1000, {});
  EXPECT_EQ(array.file(), nullptr);
  ASSERT_EQ(array.elements().size(), 1000u);
  std::iota(array.elements().begin(), array.elements().end(), std::uint16_t{0});
  const std::shared_ptr<const std::uint16_t> shared = array.share();
  EXPECT_EQ(shared.get(), array.elements().data());
  EXPECT_EQ(shared.get()[999], 999);
}

TEST(ScratchArray, WithADirectoryIsAScratchFileThereThatOutlivesTheArray) {
  test::TempDir dir;
  std::shared_ptr<const float> shared;
  {
    auto array = ScratchArray<float>::allocate(3 * MemoryMapping::pageSize(), dir.path());
    ASSERT_NE(array.file(), nullptr);
    EXPECT_EQ(array.file()->path(), dir.path());
    EXPECT_EQ(array.file()->size(), array.elements().size_bytes());
    std::iota(array.elements().begin(), array.elements().end(), 0.0f);
    ASSERT_TRUE(array.file()->releaseResident());
    shared = array.share();
  }
  EXPECT_EQ(shared.get()[1000], 1000.0f) << "the mapping lives while a shared owner does";
  EXPECT_TRUE(std::filesystem::is_empty(dir.path())) << "the scratch file has no name";
}

TEST(ScratchArray, WhereNoScratchFileCanBeMadeIsInMemory) {
  test::TempDir dir;
  auto array = ScratchArray<double>::allocate(64, dir / "missing");
  EXPECT_EQ(array.file(), nullptr);
  EXPECT_EQ(array.elements().size(), 64u);
}

}  // namespace
}  // namespace pbdam::formats
