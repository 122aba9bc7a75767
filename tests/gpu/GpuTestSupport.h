// Shared set-up for GPU tests: a VulkanContext on lavapipe with the Khronos validation layer
// forced on, and a check that the run (including destruction) produced no validation message.
#pragma once

#include "pbdam/gpu/VulkanContext.h"

#include <gtest/gtest.h>

#include <memory>
#include <optional>

namespace pbdam::gpu::test {

/// Options every GPU test uses: lavapipe, pinned by name (a machine's GPU would be its default
/// device), validation on, messages echoed.
inline ContextOptions lavapipeWithValidation(std::shared_ptr<ValidationLog> log) {
  ContextOptions options;
  options.device = "lavapipe";
  options.enableValidation = true;
  options.enableSynchronizationValidation = true;
  options.validationLog = std::move(log);
  options.applicationName = "pbdam test_gpu";
  return options;
}

/// Fixture: context() is a fresh lavapipe context with validation. TearDown destroys it and
/// fails the test if the validation layer reported anything during the test.
class GpuTest : public ::testing::Test {
 protected:
  void SetUp() override {
    formats::Result<VulkanContext> created = VulkanContext::create(lavapipeWithValidation(log_));
    ASSERT_TRUE(created.ok()) << "could not create a lavapipe Vulkan context with validation: "
                              << created.error().message;
    ASSERT_TRUE(created->deviceInfo().isLavapipe()) << describe(created->deviceInfo());
    ASSERT_TRUE(created->validationEnabled());
    context_.emplace(std::move(created).value());
  }

  void TearDown() override {
    context_.reset();  // destruction-time messages (leaked objects) count too
    EXPECT_EQ(log_->count(), 0u) << "validation messages:\n" << log_->summary();
  }

  VulkanContext& context() { return *context_; }
  ValidationLog& log() { return *log_; }

 private:
  std::shared_ptr<ValidationLog> log_ = std::make_shared<ValidationLog>(true);
  std::optional<VulkanContext> context_;
};

}  // namespace pbdam::gpu::test
