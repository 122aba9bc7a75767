// `pbdam devices`: the Vulkan devices this machine offers, in the order `--device N` counts
// them, and which one pbdam uses by default (lavapipe).
#include <nlohmann/json.hpp>

#include <iostream>

#include "Commands.h"
#include "pbdam/gpu/PhysicalDevices.h"

namespace pbdam::tools {

void addDevicesCommand(CLI::App& app, CommandStatus& status) {
  auto json = std::make_shared<bool>(false);
  CLI::App* devices = app.add_subcommand(
      "devices", "List Vulkan devices (index for --device N; lavapipe is the default)");
  devices->add_flag("--json", *json, "Machine-readable JSON output");
  devices->callback([json, &status] {
    auto list = gpu::listPhysicalDevices();
    if (!list) {
      std::cerr << "pbdam: " << list.error().message << "\n";
      status.exitCode = kExitFailure;
      return;
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
                     {"default", d.isLavapipe()}});
      }
      std::cout << j.dump(2) << "\n";
      return;
    }
    for (const auto& d : *list) {
      std::cout << gpu::describe(d) << (d.isLavapipe() ? "  (default)" : "") << "\n";
    }
  });
}

}  // namespace pbdam::tools
