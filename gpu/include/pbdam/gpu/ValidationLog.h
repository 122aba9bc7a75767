// ValidationLog: collects the warnings and errors that the Khronos validation layer (and the
// driver) report through VK_EXT_debug_utils, so tests can assert that a run produced none.
#pragma once

#include <vulkan/vulkan.h>

#include <cstddef>
#include <mutex>
#include <string>
#include <vector>

namespace pbdam::gpu {

/// One message received by the debug messenger.
struct ValidationMessage final {
  /// How severe: error, warning, info or verbose.
  VkDebugUtilsMessageSeverityFlagBitsEXT severity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
  VkDebugUtilsMessageTypeFlagsEXT types = 0;  ///< general, validation and/or performance
  std::string idName;  ///< the VUID or message id name ("VUID-vkCmdDraw-None-02859"); may be ""
  std::string text;    ///< the full message
};

/// A log of validation warnings and errors. The VulkanContext's debug messenger appends to it;
/// it can outlive the context (share it through ContextOptions::validationLog) so that messages
/// emitted while the device and instance are destroyed — leaked objects, say — are counted too.
///
/// Thread-safety: every member function is thread-safe; the layer may call record() from any
/// thread that makes Vulkan calls.
class ValidationLog final {
 public:
  /// `echoToStderr`: also print each message to stderr as it arrives.
  explicit ValidationLog(bool echoToStderr = true) noexcept : echoToStderr_(echoToStderr) {}

  ValidationLog(const ValidationLog&) = delete;
  ValidationLog& operator=(const ValidationLog&) = delete;

  /// Appends a message (and prints it to stderr if echoing).
  void record(ValidationMessage message);

  /// Number of messages recorded since construction or the last clear().
  std::size_t count() const;
  /// A copy of the recorded messages, oldest first.
  std::vector<ValidationMessage> messages() const;
  /// All recorded messages as one string, one per line, for test failure output.
  std::string summary() const;
  /// Forgets all recorded messages.
  void clear();

  /// The callback to put in VkDebugUtilsMessengerCreateInfoEXT; pUserData must point to a
  /// ValidationLog that outlives the messenger. Records warnings and errors, ignores the rest.
  static VKAPI_ATTR VkBool32 VKAPI_CALL callback(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                                 VkDebugUtilsMessageTypeFlagsEXT types,
                                                 const VkDebugUtilsMessengerCallbackDataEXT* data,
                                                 void* userData);

  /// A create-info that sends warnings and errors of every message type to `log`'s callback.
  static VkDebugUtilsMessengerCreateInfoEXT messengerCreateInfo(ValidationLog& log) noexcept;

 private:
  mutable std::mutex mutex_;
  std::vector<ValidationMessage> messages_;
  bool echoToStderr_ = true;
};

}  // namespace pbdam::gpu
