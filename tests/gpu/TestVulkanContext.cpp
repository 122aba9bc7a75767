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
#include <vector>

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
  options.device = std::to_string(lavapipe->index);
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
  options.device = "999";
  Result<VulkanContext> context = VulkanContext::create(options);
  ASSERT_FALSE(context.ok());
  EXPECT_EQ(context.error().code, ErrorCode::InvalidArgument);
  EXPECT_THAT(context.error().message, HasSubstr("device index 999 is out of range"));
  EXPECT_THAT(context.error().message, HasSubstr("llvmpipe"));  // the list of devices
  EXPECT_EQ(log->count(), 0u) << log->summary();
}

TEST(VulkanContext, ChoosesDeviceByAnyCasePartOfItsName) {
  for (const char* name : {"LavaPipe", "llvmpipe", "LLVM"}) {
    SCOPED_TRACE(name);
    auto log = std::make_shared<ValidationLog>();
    ContextOptions options = test::lavapipeWithValidation(log);
    options.device = name;
    Result<VulkanContext> context = VulkanContext::create(options);
    ASSERT_TRUE(context.ok()) << context.error().message;
    EXPECT_TRUE(context->deviceInfo().isLavapipe()) << describe(context->deviceInfo());
  }
  auto log = std::make_shared<ValidationLog>();
  ContextOptions options = test::lavapipeWithValidation(log);
  options.device = "no-such-gpu";
  Result<VulkanContext> context = VulkanContext::create(options);
  ASSERT_FALSE(context.ok());
  EXPECT_EQ(context.error().code, ErrorCode::InvalidArgument);
  EXPECT_THAT(context.error().message, HasSubstr("no Vulkan device matches 'no-such-gpu'"));
  EXPECT_THAT(context.error().message, HasSubstr("llvmpipe"));  // the list of devices
}

/// A device list as a machine with several kinds of device would report it.
std::vector<PhysicalDeviceInfo> machine(std::initializer_list<VkPhysicalDeviceType> types) {
  std::vector<PhysicalDeviceInfo> devices;
  for (const VkPhysicalDeviceType type : types) {
    PhysicalDeviceInfo d;
    d.index = static_cast<uint32_t>(devices.size());
    d.type = type;
    switch (type) {
      case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
        d.name = "NVIDIA H200";
        d.driverName = "NVIDIA";
        break;
      case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
        d.name = "Intel(R) UHD Graphics 770";
        d.driverName = "Intel open-source Mesa driver";
        break;
      case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
        d.name = "Virtio-GPU Venus";
        d.driverName = "venus";
        break;
      default:
        d.name = "llvmpipe (LLVM 15.0.6, 256 bits)";
        d.driverName = "llvmpipe";
        d.driverId = VK_DRIVER_ID_MESA_LLVMPIPE;
        break;
    }
    d.name += " #" + std::to_string(d.index);
    devices.push_back(d);
  }
  return devices;
}

TEST(PhysicalDeviceChoice, TheDefaultIsDiscreteThenIntegratedThenVirtualThenCpuTiesByIndex) {
  constexpr auto cpu = VK_PHYSICAL_DEVICE_TYPE_CPU;
  constexpr auto virt = VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU;
  constexpr auto integrated = VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU;
  constexpr auto discrete = VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU;
  EXPECT_EQ(selectPhysicalDevice(machine({cpu, integrated, discrete, discrete}), "").value(), 2u);
  EXPECT_EQ(selectPhysicalDevice(machine({cpu, virt, integrated}), "").value(), 2u);
  EXPECT_EQ(selectPhysicalDevice(machine({cpu, virt}), "").value(), 1u);
  EXPECT_EQ(selectPhysicalDevice(machine({cpu, cpu}), "").value(), 0u);
  EXPECT_EQ(defaultPhysicalDevice(machine({integrated, cpu, integrated})), 0u);
  EXPECT_EQ(defaultPhysicalDevice({}), std::nullopt);
  auto none = selectPhysicalDevice({}, "");
  ASSERT_FALSE(none.ok());
  EXPECT_EQ(none.error().code, ErrorCode::NotFound);
}

TEST(PhysicalDeviceChoice, AnIndexOrAnyCasePartOfTheDeviceOrDriverNameNamesADevice) {
  const auto devices =
      machine({VK_PHYSICAL_DEVICE_TYPE_CPU, VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU,
               VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU, VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU});
  EXPECT_EQ(selectPhysicalDevice(devices, "0").value(), 0u);
  EXPECT_EQ(selectPhysicalDevice(devices, "3").value(), 3u);
  EXPECT_EQ(selectPhysicalDevice(devices, "lavapipe").value(), 0u);
  EXPECT_EQ(selectPhysicalDevice(devices, "LLVMPIPE").value(), 0u);
  EXPECT_EQ(selectPhysicalDevice(devices, "uhd").value(), 1u);
  EXPECT_EQ(selectPhysicalDevice(devices, "mesa").value(), 1u);    // the driver's name
  EXPECT_EQ(selectPhysicalDevice(devices, "nvidia").value(), 2u);  // two match: the first
  EXPECT_EQ(selectPhysicalDevice(devices, "h200 #3").value(), 3u);
  // Of several matches the most preferred type wins: "#" is in every name.
  EXPECT_EQ(selectPhysicalDevice(devices, "#").value(), 2u);
  for (const char* bad : {"4", "99999999999999999999", "radeon"}) {
    SCOPED_TRACE(bad);
    auto refused = selectPhysicalDevice(devices, bad);
    ASSERT_FALSE(refused.ok());
    EXPECT_EQ(refused.error().code, ErrorCode::InvalidArgument);
    EXPECT_THAT(refused.error().message, HasSubstr(bad));
    EXPECT_THAT(refused.error().message, HasSubstr("4 Vulkan device(s)"));
    EXPECT_THAT(refused.error().message, HasSubstr("3: NVIDIA H200 #3"));
  }
}

TEST(PhysicalDeviceChoice, PbdamDeviceNamesTheDeviceWhenNoOptionDoes) {
  const char* saved = std::getenv(kDeviceEnvironmentVariable);
  const std::optional<std::string> restore =
      saved ? std::optional<std::string>(saved) : std::nullopt;
  ::setenv(kDeviceEnvironmentVariable, "nvidia", 1);
  EXPECT_EQ(deviceSelector(""), "nvidia");
  EXPECT_EQ(deviceSelector("lavapipe"), "lavapipe");  // the option wins
  ::unsetenv(kDeviceEnvironmentVariable);
  EXPECT_EQ(deviceSelector(""), "");
  if (restore) ::setenv(kDeviceEnvironmentVariable, restore->c_str(), 1);
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
