// ValidationLog: the VK_EXT_debug_utils messenger's sink.
#include "pbdam/gpu/ValidationLog.h"

#include <cstdio>

namespace pbdam::gpu {
namespace {

const char* severityName(VkDebugUtilsMessageSeverityFlagBitsEXT severity) noexcept {
  switch (severity) {
    case VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT:
      return "error";
    case VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT:
      return "warning";
    case VK_DEBUG_UTILS_MESSAGE_SEVERITY_INFO_BIT_EXT:
      return "info";
    default:
      return "verbose";
  }
}

std::string formatMessage(const ValidationMessage& message) {
  std::string line = "[vulkan ";
  line += severityName(message.severity);
  if ((message.types & VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT) != 0) {
    line += ", performance";
  }
  line += "] ";
  if (!message.idName.empty()) {
    line += message.idName;
    line += ": ";
  }
  line += message.text;
  return line;
}

}  // namespace

void ValidationLog::record(ValidationMessage message) {
  const std::lock_guard lock(mutex_);
  if (echoToStderr_) {
    std::fprintf(stderr, "%s\n", formatMessage(message).c_str());
  }
  messages_.push_back(std::move(message));
}

std::size_t ValidationLog::count() const {
  const std::lock_guard lock(mutex_);
  return messages_.size();
}

std::vector<ValidationMessage> ValidationLog::messages() const {
  const std::lock_guard lock(mutex_);
  return messages_;
}

std::string ValidationLog::summary() const {
  const std::lock_guard lock(mutex_);
  std::string text;
  for (const ValidationMessage& message : messages_) {
    text += formatMessage(message);
    text += '\n';
  }
  return text;
}

void ValidationLog::clear() {
  const std::lock_guard lock(mutex_);
  messages_.clear();
}

VKAPI_ATTR VkBool32 VKAPI_CALL ValidationLog::callback(
    VkDebugUtilsMessageSeverityFlagBitsEXT severity, VkDebugUtilsMessageTypeFlagsEXT types,
    const VkDebugUtilsMessengerCallbackDataEXT* data, void* userData) {
  constexpr VkDebugUtilsMessageSeverityFlagsEXT kRecorded =
      VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT |
      VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
  if ((static_cast<VkDebugUtilsMessageSeverityFlagsEXT>(severity) & kRecorded) == 0 ||
      userData == nullptr) {
    return VK_FALSE;
  }
  ValidationMessage message;
  message.severity = severity;
  message.types = types;
  if (data != nullptr) {
    if (data->pMessageIdName != nullptr) message.idName = data->pMessageIdName;
    if (data->pMessage != nullptr) message.text = data->pMessage;
  }
  // The callback runs inside the driver's call stack: it must not throw across it.
  try {
    static_cast<ValidationLog*>(userData)->record(std::move(message));
  } catch (...) {
    std::fprintf(stderr, "[vulkan] could not record a validation message\n");
  }
  return VK_FALSE;  // never abort the call that triggered the message
}

VkDebugUtilsMessengerCreateInfoEXT ValidationLog::messengerCreateInfo(ValidationLog& log) noexcept {
  VkDebugUtilsMessengerCreateInfoEXT info{};
  info.sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT;
  info.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT |
                         VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
  info.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT |
                     VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                     VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
  info.pfnUserCallback = &ValidationLog::callback;
  info.pUserData = &log;
  return info;
}

}  // namespace pbdam::gpu
