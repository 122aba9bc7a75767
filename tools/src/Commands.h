// Registration of the `pbdam` subcommands. Each adds itself to the CLI11 app and sets the exit
// code through CommandStatus when it runs.
#pragma once

#include <CLI/CLI.hpp>

namespace pbdam::tools {

/// Exit codes: 0 success, 1 internal failure, 2 bad input (unreadable file, bad parameter).
enum ExitCode : int { kExitOk = 0, kExitFailure = 1, kExitBadInput = 2 };

/// Shared by all commands: the code `main` returns after the chosen command ran.
struct CommandStatus final {
  int exitCode = kExitOk;
};

/// `pbdam dem info FILE [--at LAT,LON] [--json] [raw options]`.
void addDemCommands(CLI::App& app, CommandStatus& status);

/// `pbdam devices [--json]`.
void addDevicesCommand(CLI::App& app, CommandStatus& status);

}  // namespace pbdam::tools
