// Registration of the `pbdam` subcommands. Each adds itself to the CLI11 app and sets the exit
// code through CommandStatus when it runs.
#pragma once

#include <CLI/CLI.hpp>
#include <string>

#include "pbdam/formats/Result.h"

namespace pbdam::tools {

/// Exit codes: 0 success, 1 internal failure, 2 bad input (unreadable file, bad parameter).
enum ExitCode : int { kExitOk = 0, kExitFailure = 1, kExitBadInput = 2 };

/// The help of every command's --device option (gpu::selectPhysicalDevice resolves it).
inline constexpr const char* kDeviceOptionHelp =
    "Vulkan device: an index or a case-insensitive part of its name (pbdam devices); default: "
    "PBDAM_DEVICE, else the best device (discrete > integrated > virtual > CPU)";

inline constexpr const char* kFramesInFlightHelp =
    "Frames submitted to the device and not yet collected (1-8): the next frame is refined, "
    "decoded and recorded while the device draws; 1 waits for each frame before the next";

/// Shared by all commands: the code `main` returns after the chosen command ran.
struct CommandStatus final {
  int exitCode = kExitOk;
};

/// `pbdam dem info FILE [--at LAT,LON] [--json] [raw options]`.
void addDemCommands(CLI::App& app, CommandStatus& status);

/// `pbdam devices [--json]`.
void addDevicesCommand(CLI::App& app, CommandStatus& status);

/// `pbdam build --dem FILE --planet P --out DIR [...]`.
void addBuildCommand(CLI::App& app, CommandStatus& status);

/// `pbdam info DIR [--json]` and `pbdam verify DIR [--dem FILE]`.
void addDatasetCommands(CLI::App& app, CommandStatus& status);

/// `pbdam height DIR --at LAT,LON [--json]`.
void addHeightCommand(CLI::App& app, CommandStatus& status);

/// `pbdam render DIR (--camera POSE | --path FILE) --out PATH [...]`.
void addRenderCommand(CLI::App& app, CommandStatus& status);

/// `pbdam path great-circle|waypoints … --out FILE`.
void addPathCommands(CLI::App& app, CommandStatus& status);

/// `pbdam bench DIR --path FILE --out REPORTDIR [...]`.
void addBenchCommand(CLI::App& app, CommandStatus& status);

/// `pbdam serve DIR [--bind A] [--port N] [--workers N] [--queue N] [--gpu-cache-mb N] [...]`.
void addServeCommand(CLI::App& app, CommandStatus& status);
/// `pbdam fly`: an interactive flythrough in a window (FlyCommand.cpp).
void addFlyCommand(CLI::App& app, CommandStatus& status);

/// `pbdam query cut DIR (--camera POSE | --focus … | --focus-path …) --out MESH.ply [--json]`.
void addQueryCommands(CLI::App& app, CommandStatus& status);

/// Prints "pbdam: <message>" on stderr; returns the exit code for the error's kind.
int reportError(const formats::Error& error);

/// InvalidArgument naming `out` when the directory it would go into does not exist: checked
/// before any work, so that a mistyped path costs nothing.
formats::Result<void> checkOutputDirectory(const std::string& out);

}  // namespace pbdam::tools
