// `pbdam devices`: the Vulkan devices this machine offers, in the order `--device N` counts
// them, and which one pbdam uses when no --device is given (PBDAM_DEVICE's choice if it is set,
// else the best device: gpu::selectPhysicalDevice).
#include <nlohmann/json.hpp>

#include <cstdint>
#include <iostream>
#include <optional>

#include "Commands.h"
#include "pbdam/gpu/PhysicalDevices.h"

namespace pbdam::tools {

void addDevicesCommand(CLI::App& app, CommandStatus& status) {
  auto json = std::make_shared<bool>(false);
  CLI::App* devices = app.add_subcommand(
      "devices",
      "List Vulkan devices (--device takes an index or part of a name) and mark the default");
  devices->add_flag("--json", *json, "Machine-readable JSON output");
  devices->callback([json, &status] {
    auto list = gpu::listPhysicalDevices();
    if (!list) {
      std::cerr << "pbdam: " << list.error().message << "\n";
      status.exitCode = kExitFailure;
      return;
    }
    // The device a command without --device runs on; none when PBDAM_DEVICE names nothing.
    std::optional<std::uint32_t> chosen;
    if (auto selected = gpu::selectPhysicalDevice(*list, gpu::deviceSelector(""))) {
      chosen = *selected;
    } else {
      std::cerr << "pbdam: " << gpu::kDeviceEnvironmentVariable << ": " << selected.error().message
                << "\n";
    }
    if (*json) {
      nlohmann::ordered_json j = nlohmann::ordered_json::array();
      for (const auto& d : *list) {
        j.push_back({{"index", d.index},
                     {"name", d.name},
                     {"type", gpu::physicalDeviceTypeName(d.type)},
                     {"driver", d.driverName},
                     {"driver_info", d.driverInfo},
                     {"api_version", gpu::apiVersionString(d.apiVersion)},
                     {"default", chosen == d.index}});
      }
      std::cout << j.dump(2) << "\n";
      return;
    }
    for (const auto& d : *list) {
      std::cout << gpu::describe(d) << (chosen == d.index ? "  (default)" : "") << "\n";
    }
  });
}

}  // namespace pbdam::tools
