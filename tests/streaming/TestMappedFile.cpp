// Read-only mappings: contents, ownership transfer, madvise/mincore, errors naming the file.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <unistd.h>

#include <cstring>
#include <fstream>

#include "TestData.h"
#include "pbdam/streaming/MappedFile.h"

namespace pbdam {
namespace {

TEST(MappedFile, MapsTheFileContents) {
  test::TempDir dir;
  std::string content(3 * MappedFile::pageSize() + 17, '\0');
  for (std::size_t k = 0; k < content.size(); ++k) content[k] = static_cast<char>(k * 31 % 251);
  std::ofstream(dir / "f.bin", std::ios::binary)
      .write(content.data(), static_cast<std::streamsize>(content.size()));
  auto file = MappedFile::open(dir / "f.bin");
  ASSERT_TRUE(file) << file.error().message;
  ASSERT_EQ(file->size(), content.size());
  EXPECT_EQ(std::memcmp(file->bytes().data(), content.data(), content.size()), 0);
  EXPECT_TRUE(file->advise(MappingAdvice::Random));
  EXPECT_TRUE(file->willNeed(MappedFile::pageSize() + 5, 100));
  auto resident = file->residentPages();
  ASSERT_TRUE(resident);
  EXPECT_LE(*resident, 4u);
  EXPECT_GE(*resident, 1u);  // just written: in the page cache

  MappedFile moved = std::move(*file);
  EXPECT_EQ(file->size(), 0u);  // NOLINT(bugprone-use-after-move): moved-from is empty
  EXPECT_TRUE(file->bytes().empty());
  EXPECT_EQ(moved.size(), content.size());
  EXPECT_EQ(static_cast<char>(moved.bytes()[100]), content[100]);
}

TEST(MappedFile, EmptyFileGivesEmptyMapping) {
  test::TempDir dir;
  std::ofstream(dir / "empty.bin").close();
  auto file = MappedFile::open(dir / "empty.bin");
  ASSERT_TRUE(file);
  EXPECT_EQ(file->size(), 0u);
  EXPECT_EQ(*file->residentPages(), 0u);
}

TEST(MappedFile, ErrorsNameTheFile) {
  test::TempDir dir;
  auto missing = MappedFile::open(dir / "missing.bin");
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().code, ErrorCode::NotFound);
  EXPECT_NE(missing.error().message.find("missing.bin"), std::string::npos);
  auto directory = MappedFile::open(dir.path());
  ASSERT_FALSE(directory);
  EXPECT_NE(directory.error().message.find(dir.path().filename().string()), std::string::npos);
}

}  // namespace
}  // namespace pbdam
