// RAII owners: UniqueHandle, GpuBuffer and GpuImage destroy exactly once and are empty after a
// move.
#include "GpuTestSupport.h"

#include "pbdam/gpu/GpuMemory.h"
#include "pbdam/gpu/UniqueHandle.h"

#include <gtest/gtest.h>

#include <array>
#include <cstddef>
#include <utility>
#include <vector>

using namespace pbdam::formats;

namespace pbdam::gpu {
namespace {

// A fake destroy function: records which handles were destroyed, with which parent.
std::vector<std::pair<VkDevice, VkFence>>& destroyed() {
  static std::vector<std::pair<VkDevice, VkFence>> calls;
  return calls;
}
void fakeDestroyFence(VkDevice device, VkFence fence, const VkAllocationCallbacks*) {
  destroyed().emplace_back(device, fence);
}
using FakeFence = UniqueHandle<VkFence, VkDevice, &fakeDestroyFence>;

// Distinct non-null fake handles (never dereferenced): addresses inside one static array, so
// no integer is turned into a pointer.
std::byte* fakeHandleStorage() {
  static std::array<std::byte, 16> storage{};
  return storage.data();
}
VkDevice fakeDevice() { return reinterpret_cast<VkDevice>(fakeHandleStorage()); }
VkFence fakeFence(std::size_t n) { return reinterpret_cast<VkFence>(fakeHandleStorage() + n); }

TEST(UniqueHandle, DestroysOnceWithItsParent) {
  destroyed().clear();
  {
    const FakeFence owner(fakeDevice(), fakeFence(1));
    EXPECT_TRUE(owner);
    EXPECT_EQ(owner.get(), fakeFence(1));
    EXPECT_TRUE(destroyed().empty());
  }
  ASSERT_EQ(destroyed().size(), 1u);
  EXPECT_EQ(destroyed()[0].first, fakeDevice());
  EXPECT_EQ(destroyed()[0].second, fakeFence(1));
}

TEST(UniqueHandle, MoveConstructionLeavesTheSourceEmpty) {
  destroyed().clear();
  {
    FakeFence source(fakeDevice(), fakeFence(2));
    FakeFence target(std::move(source));
    EXPECT_FALSE(source);  // NOLINT(bugprone-use-after-move): testing the moved-from state
    EXPECT_EQ(source.get(), VK_NULL_HANDLE);
    EXPECT_EQ(source.parent(), VK_NULL_HANDLE);
    EXPECT_EQ(target.get(), fakeFence(2));
    EXPECT_EQ(target.parent(), fakeDevice());
  }
  ASSERT_EQ(destroyed().size(), 1u);  // once, by the target
  EXPECT_EQ(destroyed()[0].second, fakeFence(2));
}

TEST(UniqueHandle, MoveAssignmentDestroysTheOverwrittenHandle) {
  destroyed().clear();
  {
    FakeFence a(fakeDevice(), fakeFence(3));
    FakeFence b(fakeDevice(), fakeFence(4));
    a = std::move(b);
    ASSERT_EQ(destroyed().size(), 1u);
    EXPECT_EQ(destroyed()[0].second, fakeFence(3));
    EXPECT_FALSE(b);  // NOLINT(bugprone-use-after-move)
    EXPECT_EQ(a.get(), fakeFence(4));
    FakeFence& alias = a;
    a = std::move(alias);  // self-move keeps the handle
    EXPECT_EQ(a.get(), fakeFence(4));
  }
  ASSERT_EQ(destroyed().size(), 2u);
  EXPECT_EQ(destroyed()[1].second, fakeFence(4));
}

TEST(UniqueHandle, ReleaseAndResetAndEmptyOwners) {
  destroyed().clear();
  {
    const FakeFence empty;
    EXPECT_FALSE(empty);
    FakeFence released(fakeDevice(), fakeFence(5));
    EXPECT_EQ(released.release(), fakeFence(5));
    EXPECT_FALSE(released);
    FakeFence reset(fakeDevice(), fakeFence(6));
    reset.reset();
    EXPECT_FALSE(reset);
    ASSERT_EQ(destroyed().size(), 1u);
    EXPECT_EQ(destroyed()[0].second, fakeFence(6));
  }
  EXPECT_EQ(destroyed().size(), 1u);  // the empty, released and reset owners destroy nothing
}

using GpuOwners = test::GpuTest;

TEST_F(GpuOwners, GpuBufferMovesItsHandlesAndMapping) {
  Result<GpuBuffer> created = createBuffer(context(), 256, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                           MemoryUse::HostReadback, "move test buffer");
  ASSERT_TRUE(created.ok()) << created.error().message;
  GpuBuffer first = std::move(created).value();
  VkBuffer handle = first.buffer();
  ASSERT_NE(handle, VK_NULL_HANDLE);
  ASSERT_EQ(first.mappedBytes().size(), 256u);

  GpuBuffer second(std::move(first));
  EXPECT_FALSE(first);  // NOLINT(bugprone-use-after-move)
  EXPECT_EQ(first.buffer(), VK_NULL_HANDLE);
  EXPECT_EQ(first.memory(), VK_NULL_HANDLE);
  EXPECT_TRUE(first.mappedBytes().empty());
  EXPECT_EQ(second.buffer(), handle);
  EXPECT_EQ(second.sizeBytes(), 256u);

  Result<GpuBuffer> other = createBuffer(context(), 64, VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                         MemoryUse::HostUpload, "overwritten buffer");
  ASSERT_TRUE(other.ok()) << other.error().message;
  GpuBuffer third = std::move(other).value();
  third = std::move(second);  // destroys the 64-byte buffer; a leak would be reported
  EXPECT_FALSE(second);       // NOLINT(bugprone-use-after-move)
  EXPECT_EQ(third.buffer(), handle);
  EXPECT_EQ(third.sizeBytes(), 256u);
}

TEST_F(GpuOwners, GpuImageMovesItsHandles) {
  ImageDesc desc;
  desc.widthPixels = 8;
  desc.heightPixels = 4;
  desc.usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT;
  Result<GpuImage> created = createImage2D(context(), desc, "move test image");
  ASSERT_TRUE(created.ok()) << created.error().message;
  GpuImage first = std::move(created).value();
  VkImage image = first.image();
  VkImageView view = first.view();
  GpuImage second;
  second = std::move(first);
  EXPECT_FALSE(first);  // NOLINT(bugprone-use-after-move)
  EXPECT_EQ(first.view(), VK_NULL_HANDLE);
  EXPECT_EQ(second.image(), image);
  EXPECT_EQ(second.view(), view);
  EXPECT_EQ(second.extent().width, 8u);
  EXPECT_EQ(second.extent().height, 4u);
}

TEST(GpuMemory, FindMemoryTypePrefersButDoesNotRequirePreferredFlags) {
  VkPhysicalDeviceMemoryProperties properties{};
  properties.memoryTypeCount = 3;
  properties.memoryTypes[0].propertyFlags = VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT;
  properties.memoryTypes[1].propertyFlags =
      VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
  properties.memoryTypes[2].propertyFlags = VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT |
                                            VK_MEMORY_PROPERTY_HOST_COHERENT_BIT |
                                            VK_MEMORY_PROPERTY_HOST_CACHED_BIT;
  EXPECT_EQ(findMemoryType(properties, 0b111, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT,
                           VK_MEMORY_PROPERTY_HOST_CACHED_BIT),
            2u);
  // Type 2 not allowed: falls back to the visible-but-uncached type.
  EXPECT_EQ(findMemoryType(properties, 0b011, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT,
                           VK_MEMORY_PROPERTY_HOST_CACHED_BIT),
            1u);
  EXPECT_EQ(findMemoryType(properties, 0b001, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT), std::nullopt);
}

}  // namespace
}  // namespace pbdam::gpu
