// ScratchArray: N elements a builder stage writes and later reads, held either in memory or in
// an unnamed scratch file mapped from a directory (MemoryMapping::createScratch), so that the
// outputs of an out-of-core input stay out of core too. Thread-safety: none for one array; the
// elements' shared owners may be passed to and read from any thread.
#pragma once

#include <cstddef>
#include <filesystem>
#include <memory>
#include <span>
#include <type_traits>
#include <utility>

#include "pbdam/formats/MemoryMapping.h"

namespace pbdam::formats {

/// `count` elements of T in memory or in a mapped scratch file (see the file comment).
/// Move-only.
template <class T>
class ScratchArray final {
  static_assert(std::is_trivially_copyable_v<T>, "scratch files hold trivially copyable elements");

 public:
  /// `count` uninitialised elements: in a scratch file in `scratchDirectory` when it is not
  /// empty and one can be made there (a full disk or a filesystem without unnamed files falls
  /// back silently), in memory otherwise.
  static ScratchArray allocate(std::size_t count, const std::filesystem::path& scratchDirectory) {
    ScratchArray array;
    array.count_ = count;
    if (!scratchDirectory.empty() && count > 0) {
      if (auto m = MemoryMapping::createScratch(scratchDirectory, count * sizeof(T))) {
        array.file_ = std::make_shared<MemoryMapping>(std::move(m).value());
        // The mapping is page-aligned, so any T is aligned in it.
        array.data_ = reinterpret_cast<T*>(array.file_->writableBytes().data());
        array.owner_ = array.file_;
        return array;
      }
    }
    auto memory = std::make_shared_for_overwrite<T[]>(count);
    array.data_ = memory.get();
    array.owner_ = std::move(memory);
    return array;
  }

  /// Moves the elements' ownership to the new array.
  /// @{
  ScratchArray(ScratchArray&&) noexcept = default;
  ScratchArray& operator=(ScratchArray&&) noexcept = default;
  /// @}
  ScratchArray(const ScratchArray&) = delete;
  ScratchArray& operator=(const ScratchArray&) = delete;
  ~ScratchArray() = default;

  /// The elements, for writing.
  std::span<T> elements() const noexcept { return {data_, count_}; }
  /// The scratch mapping behind the elements; null when they are in memory.
  const std::shared_ptr<MemoryMapping>& file() const noexcept { return file_; }
  /// A shared owner of the elements (of the mapping or the memory), pointing at the first:
  /// they live while any copy of it does, also after this array is gone.
  std::shared_ptr<const T> share() const noexcept { return {owner_, data_}; }

 private:
  ScratchArray() = default;
  T* data_ = nullptr;
  std::size_t count_ = 0;
  std::shared_ptr<const void> owner_;
  std::shared_ptr<MemoryMapping> file_;
};

}  // namespace pbdam::formats
