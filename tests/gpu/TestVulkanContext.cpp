// VulkanContext: headless creation on lavapipe with validation, device listing and selection,
// capabilities, and the validation messenger itself.
#include "GpuTestSupport.h"
#include "TestData.h"

#include "pbdam/gpu/PhysicalDevices.h"
#include "pbdam/gpu/VulkanContext.h"
#include "pbdam/gpu/VulkanError.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <memory>
#include <optional>
#include <string>

using namespace pbdam::formats;

namespace pbdam::gpu {
namespace {

using ::testing::HasSubstr;

TEST(PhysicalDevices, ListsLavapipe) {
  Result<std::vector<PhysicalDeviceInfo>> devices = listPhysicalDevices();
  ASSERT_TRUE(devices.ok()) << devices.error().message;
  const auto lavapipe = std::find_if(devices->begin(), devices->end(),
                                     [](const PhysicalDeviceInfo& d) { return d.isLavapipe(); });
  ASSERT_NE(lavapipe, devices->end())
      << "lavapipe not found (install mesa-vulkan-drivers; VK_ICD_FILENAMES must include "
         "lvp_icd.x86_64.json when set)";
  EXPECT_EQ(lavapipe->type, VK_PHYSICAL_DEVICE_TYPE_CPU);
  EXPECT_EQ(lavapipe->driverId, VK_DRIVER_ID_MESA_LLVMPIPE);
  EXPECT_GE(lavapipe->apiVersion, VK_API_VERSION_1_3);
  for (std::size_t i = 0; i < devices->size(); ++i) EXPECT_EQ((*devices)[i].index, i);
  const std::string line = describe(*lavapipe);
  EXPECT_THAT(line, HasSubstr("llvmpipe"));
  EXPECT_THAT(line, HasSubstr("[cpu, driver llvmpipe"));
  EXPECT_THAT(line, HasSubstr("Vulkan 1.3."));
}

using VulkanContextTest = test::GpuTest;

TEST_F(VulkanContextTest, CreatesHeadlessLavapipeDeviceWithValidation) {
  EXPECT_NE(context().instance(), VK_NULL_HANDLE);
  EXPECT_NE(context().device(), VK_NULL_HANDLE);
  EXPECT_NE(context().queue(), VK_NULL_HANDLE);
  EXPECT_EQ(context().deviceInfo().driverId, VK_DRIVER_ID_MESA_LLVMPIPE);
  EXPECT_TRUE(context().validationEnabled());
  // An empty submission round-trips through the queue and the fence.
  Result<void> submitted = context().submitAndWait([](VkCommandBuffer) {}, "empty");
  EXPECT_TRUE(submitted.ok()) << submitted.error().message;
  EXPECT_TRUE(context().waitIdle().ok());
}

TEST_F(VulkanContextTest, RecordsLavapipeCapabilities) {
  // docs/architecture.md "Measured facts": lavapipe (Mesa 22.3) has all of these; the renderer
  // relies on the limits.
  const DeviceCaps& caps = context().caps();
  EXPECT_TRUE(caps.shaderFloat64);
  EXPECT_TRUE(caps.storageBuffer16BitAccess);
  EXPECT_TRUE(caps.textureCompressionBC);
  EXPECT_TRUE(caps.multiDrawIndirect);
  EXPECT_GE(caps.maxPushConstantsBytes, 128u);
  EXPECT_GE(caps.maxImageDimension2DPixels, 4096u);
  EXPECT_GT(caps.nonCoherentAtomSizeBytes, 0u);
}

TEST_F(VulkanContextTest, CreatesTimelineSemaphores) {
  Result<UniqueSemaphore> semaphore = context().createTimelineSemaphore(7);
  ASSERT_TRUE(semaphore.ok()) << semaphore.error().message;
  uint64_t value = 0;
  ASSERT_EQ(vkGetSemaphoreCounterValue(context().device(), semaphore->get(), &value), VK_SUCCESS);
  EXPECT_EQ(value, 7u);
}

TEST_F(VulkanContextTest, ValidationMessengerRecordsInvalidUsage) {
  // Proves the layer is really active: an invalid flag bit in VkFenceCreateInfo is reported
  // (VUID-VkFenceCreateInfo-flags-parameter) and recorded; the fence is still created.
  VkFenceCreateInfo info{};
  info.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
  info.flags = 0x40;
  VkFence raw = VK_NULL_HANDLE;
  const VkResult result = vkCreateFence(context().device(), &info, nullptr, &raw);
  const UniqueFence fence(context().device(), raw);
  ASSERT_EQ(result, VK_SUCCESS);
  ASSERT_GE(log().count(), 1u);
  bool found = false;
  for (const ValidationMessage& message : log().messages()) {
    found = found || message.idName.find("VkFenceCreateInfo-flags") != std::string::npos;
  }
  EXPECT_TRUE(found) << log().summary();
  log().clear();  // the fixture then checks that nothing else was reported
}

TEST(VulkanContext, ChoosesDeviceByExplicitIndex) {
  Result<std::vector<PhysicalDeviceInfo>> devices = listPhysicalDevices();
  ASSERT_TRUE(devices.ok()) << devices.error().message;
  const auto lavapipe = std::find_if(devices->begin(), devices->end(),
                                     [](const PhysicalDeviceInfo& d) { return d.isLavapipe(); });
  ASSERT_NE(lavapipe, devices->end());
  auto log = std::make_shared<ValidationLog>();
  ContextOptions options = test::lavapipeWithValidation(log);
  options.deviceIndex = lavapipe->index;
  {
    Result<VulkanContext> context = VulkanContext::create(options);
    ASSERT_TRUE(context.ok()) << context.error().message;
    EXPECT_EQ(context->deviceInfo().index, lavapipe->index);
    EXPECT_EQ(context->deviceInfo().name, lavapipe->name);
  }
  EXPECT_EQ(log->count(), 0u) << log->summary();
}

TEST(VulkanContext, RejectsAnOutOfRangeDeviceIndexAndListsTheDevices) {
  auto log = std::make_shared<ValidationLog>();
  ContextOptions options = test::lavapipeWithValidation(log);
  options.deviceIndex = 999;
  Result<VulkanContext> context = VulkanContext::create(options);
  ASSERT_FALSE(context.ok());
  EXPECT_EQ(context.error().code, ErrorCode::InvalidArgument);
  EXPECT_THAT(context.error().message, HasSubstr("device index 999 is out of range"));
  EXPECT_THAT(context.error().message, HasSubstr("llvmpipe"));  // the list of devices
  EXPECT_EQ(log->count(), 0u) << log->summary();
}

TEST(VulkanContext, MovedFromContextIsEmptyAndTheTargetWorks) {
  auto log = std::make_shared<ValidationLog>();
  Result<VulkanContext> created = VulkanContext::create(test::lavapipeWithValidation(log));
  ASSERT_TRUE(created.ok()) << created.error().message;
  VulkanContext first = std::move(created).value();
  VkDevice device = first.device();
  VulkanContext second = std::move(first);
  EXPECT_FALSE(first);  // NOLINT(bugprone-use-after-move): testing the moved-from state
  EXPECT_TRUE(second);
  EXPECT_EQ(second.device(), device);
  EXPECT_TRUE(second.submitAndWait([](VkCommandBuffer) {}, "after move").ok());
  EXPECT_EQ(log->count(), 0u) << log->summary();
}

// Runs `body` with environment variable `name` set to `value`, restoring it afterwards.
template <typename Body>
void withEnv(const char* name, const std::string& value, Body body) {
  const char* old = std::getenv(name);
  const std::optional<std::string> saved = old ? std::optional<std::string>(old) : std::nullopt;
  ::setenv(name, value.c_str(), 1);
  body();
  if (saved) {
    ::setenv(name, saved->c_str(), 1);
  } else {
    ::unsetenv(name);
  }
}

TEST(VulkanContext, MissingValidationLayerIsAClearError) {
  // VK_LAYER_PATH replaces the loader's search path for explicit layers: an empty directory
  // hides VK_LAYER_KHRONOS_validation.
  const pbdam::test::TempDir emptyLayerDir;
  withEnv("VK_LAYER_PATH", emptyLayerDir.path().string(), [] {
    ContextOptions options;
    options.enableValidation = true;
    Result<VulkanContext> context = VulkanContext::create(options);
    ASSERT_FALSE(context.ok());
    EXPECT_EQ(context.error().code, ErrorCode::NotFound);
    EXPECT_THAT(context.error().message, HasSubstr("VK_LAYER_KHRONOS_validation"));
    EXPECT_THAT(context.error().message, HasSubstr("vulkan-validationlayers"));
  });
}

TEST(VulkanContext, MissingDriverIsAClearError) {
  const pbdam::test::TempDir emptyDir;
  withEnv("VK_ICD_FILENAMES", (emptyDir.path() / "no_such_icd.json").string(), [] {
    ContextOptions options;
    options.enableValidation = false;
    Result<VulkanContext> context = VulkanContext::create(options);
    ASSERT_FALSE(context.ok());
    EXPECT_THAT(context.error().message, HasSubstr("VK_ICD_FILENAMES"));
  });
}

TEST(VulkanError, NamesTheResultAndExplainsIt) {
  const Error error = vulkanError(VK_ERROR_LAYER_NOT_PRESENT, "vkCreateInstance");
  EXPECT_EQ(error.code, ErrorCode::DeviceError);
  EXPECT_THAT(error.message, HasSubstr("vkCreateInstance: VK_ERROR_LAYER_NOT_PRESENT"));
  EXPECT_THAT(error.message, HasSubstr("vulkan-validationlayers"));
  EXPECT_STREQ(vkResultName(VK_ERROR_DEVICE_LOST), "VK_ERROR_DEVICE_LOST");
  EXPECT_THAT(vulkanError(static_cast<VkResult>(-12345), "x").message, HasSubstr("(-12345)"));
}

}  // namespace
}  // namespace pbdam::gpu
