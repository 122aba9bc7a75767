// Memory mappings: read-only file mappings (contents, ownership transfer, madvise/mincore,
// errors naming the file), writable file and scratch mappings (space reserved up front, so a
// full disk is an error and not a SIGBUS), and page release keeping the data.
#include <gtest/gtest.h>

#include <sys/stat.h>

#include <cstring>
#include <fstream>
#include <iterator>
#include <string>

#include "TestData.h"
#include "pbdam/formats/MemoryMapping.h"

using namespace pbdam::formats;

namespace pbdam::formats {
namespace {

TEST(MemoryMapping, MapsTheFileContents) {
  test::TempDir dir;
  std::string content(3 * MemoryMapping::pageSize() + 17, '\0');
  for (std::size_t k = 0; k < content.size(); ++k) content[k] = static_cast<char>(k * 31 % 251);
  std::ofstream(dir / "f.bin", std::ios::binary)
      .write(content.data(), static_cast<std::streamsize>(content.size()));
  auto file = MemoryMapping::open(dir / "f.bin");
  ASSERT_TRUE(file) << file.error().message;
  ASSERT_EQ(file->size(), content.size());
  EXPECT_EQ(std::memcmp(file->bytes().data(), content.data(), content.size()), 0);
  EXPECT_TRUE(file->advise(MappingAdvice::Random));
  EXPECT_TRUE(file->willNeed(MemoryMapping::pageSize() + 5, 100));
  auto resident = file->residentPages();
  ASSERT_TRUE(resident);
  EXPECT_LE(*resident, 4u);
  EXPECT_GE(*resident, 1u);  // just written: in the page cache

  MemoryMapping moved = std::move(*file);
  EXPECT_EQ(file->size(), 0u);  // NOLINT(bugprone-use-after-move): moved-from is empty
  EXPECT_TRUE(file->bytes().empty());
  EXPECT_EQ(moved.size(), content.size());
  EXPECT_EQ(static_cast<char>(moved.bytes()[100]), content[100]);
}

TEST(MemoryMapping, EmptyFileGivesEmptyMapping) {
  test::TempDir dir;
  std::ofstream(dir / "empty.bin").close();
  auto file = MemoryMapping::open(dir / "empty.bin");
  ASSERT_TRUE(file);
  EXPECT_EQ(file->size(), 0u);
  EXPECT_EQ(*file->residentPages(), 0u);
}

TEST(MemoryMapping, ErrorsNameTheFile) {
  test::TempDir dir;
  auto missing = MemoryMapping::open(dir / "missing.bin");
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().code, ErrorCode::NotFound);
  EXPECT_NE(missing.error().message.find("missing.bin"), std::string::npos);
  auto directory = MemoryMapping::open(dir.path());
  ASSERT_FALSE(directory);
  EXPECT_NE(directory.error().message.find(dir.path().filename().string()), std::string::npos);
}

/// Fills `bytes` with a pattern that differs from page to page.
void fillPattern(std::span<std::byte> bytes) {
  for (std::size_t k = 0; k < bytes.size(); ++k) bytes[k] = static_cast<std::byte>(k * 7 % 253);
}

bool hasPattern(std::span<const std::byte> bytes) {
  for (std::size_t k = 0; k < bytes.size(); ++k) {
    if (bytes[k] != static_cast<std::byte>(k * 7 % 253)) return false;
  }
  return true;
}

TEST(MemoryMapping, CreateReservesTheFileAndWritesThrough) {
  test::TempDir dir;
  const std::size_t size = 3 * MemoryMapping::pageSize() + 5;
  auto mapping = MemoryMapping::create(dir / "w.bin", size);
  ASSERT_TRUE(mapping) << mapping.error().message;
  ASSERT_TRUE(mapping->writable());
  ASSERT_EQ(mapping->writableBytes().size(), size);
  struct stat st {};
  ASSERT_EQ(::stat((dir / "w.bin").c_str(), &st), 0);
  EXPECT_EQ(static_cast<std::size_t>(st.st_size), size);
  // Reserved, not sparse: every block of the file is allocated before the first write.
  EXPECT_GE(static_cast<std::size_t>(st.st_blocks) * 512, size);
  fillPattern(mapping->writableBytes());
  ASSERT_TRUE(mapping->sync());
  std::ifstream in(dir / "w.bin", std::ios::binary);
  const std::string onDisk((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_EQ(onDisk.size(), size);
  EXPECT_TRUE(hasPattern(std::as_bytes(std::span(onDisk))));
}

TEST(MemoryMapping, CreateTruncatesAnExistingFile) {
  test::TempDir dir;
  std::ofstream(dir / "w.bin", std::ios::binary) << std::string(10000, 'x');
  auto mapping = MemoryMapping::create(dir / "w.bin", 100);
  ASSERT_TRUE(mapping) << mapping.error().message;
  EXPECT_EQ(std::filesystem::file_size(dir / "w.bin"), 100u);
  EXPECT_EQ(mapping->bytes()[0], std::byte{0});
}

TEST(MemoryMapping, SpaceThatCannotBeReservedIsAnErrorNamingTheFile) {
  test::TempDir dir;
  // No filesystem holds an exabyte: posix_fallocate fails (ENOSPC or EFBIG) before any page is
  // mapped, where an unreserved mapping would have faulted with SIGBUS on a write.
  auto mapping = MemoryMapping::create(dir / "huge.bin", std::size_t{1} << 60);
  ASSERT_FALSE(mapping);
  EXPECT_EQ(mapping.error().code, ErrorCode::NoSpace);
  EXPECT_NE(mapping.error().message.find("huge.bin"), std::string::npos);
  EXPECT_NE(mapping.error().message.find("no space to reserve 1152921504606846976 bytes"),
            std::string::npos)
      << mapping.error().message;
  auto scratch = MemoryMapping::createScratch(dir.path(), std::size_t{1} << 60);
  ASSERT_FALSE(scratch);
  EXPECT_EQ(scratch.error().code, ErrorCode::NoSpace);
  EXPECT_NE(scratch.error().message.find("reserve"), std::string::npos);
  EXPECT_NE(scratch.error().message.find(dir.path().string()), std::string::npos);
}

TEST(MemoryMapping, CreateInAMissingDirectoryFails) {
  test::TempDir dir;
  auto mapping = MemoryMapping::create(dir / "missing" / "w.bin", 100);
  ASSERT_FALSE(mapping);
  EXPECT_NE(mapping.error().message.find("cannot create"), std::string::npos);
  auto scratch = MemoryMapping::createScratch(dir / "missing", 100);
  ASSERT_FALSE(scratch);
  EXPECT_NE(scratch.error().message.find("missing"), std::string::npos);
}

TEST(MemoryMapping, ScratchIsUnnamedAndKeepsItsDataAcrossReleases) {
  test::TempDir dir;
  const std::size_t page = MemoryMapping::pageSize();
  auto scratch = MemoryMapping::createScratch(dir.path(), 8 * page);
  ASSERT_TRUE(scratch) << scratch.error().message;
  // Nothing in the directory: the space goes back with the mapping.
  EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
  fillPattern(scratch->writableBytes());
  // Releasing drops page-table entries only: a shared file mapping reads its data back (an
  // anonymous one would read zeros).
  ASSERT_TRUE(scratch->releaseResident(page + 3, 2 * page));
  EXPECT_TRUE(hasPattern(scratch->bytes()));
  dropMappedPages(scratch->bytes().data() + 5 * page + 1, page);
  EXPECT_TRUE(hasPattern(scratch->bytes()));
  ASSERT_TRUE(scratch->releaseResident());
  EXPECT_TRUE(hasPattern(scratch->bytes()));
  ASSERT_TRUE(scratch->protectReadOnly());
  EXPECT_FALSE(scratch->writable());
  EXPECT_TRUE(scratch->writableBytes().empty());
  EXPECT_TRUE(hasPattern(scratch->bytes()));
}

TEST(MemoryMapping, MoveAssignmentReleasesTheOldMapping) {
  test::TempDir dir;
  auto a = MemoryMapping::createScratch(dir.path(), 4096);
  auto b = MemoryMapping::createScratch(dir.path(), std::size_t{2} * 4096);
  ASSERT_TRUE(a && b);
  *a = std::move(*b);
  EXPECT_EQ(a->size(), 2u * 4096);
  EXPECT_TRUE(a->writable());
  EXPECT_FALSE(b->writable());  // NOLINT(bugprone-use-after-move): moved-from is empty
  EXPECT_EQ(b->size(), 0u);
}

}  // namespace
}  // namespace pbdam::formats
