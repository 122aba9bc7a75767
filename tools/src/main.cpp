// The `pbdam` command line: subcommands for inspecting inputs (dem), and later building,
// rendering, benchmarking and serving datasets.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <exception>
#include <iostream>

#include "Commands.h"
#include "MpiLauncher.h"
#include "pbdam/formats/GuardedCopy.h"

namespace {

int run(int argc, char** argv) {
  CLI::App app{
      "pbdam: out-of-core planet-scale terrain (P-BDAM) — build, inspect and render "
      "planet datasets",
      "pbdam"};
  app.set_version_flag("--version", std::string("pbdam ") + PBDAM_VERSION);
  app.require_subcommand(1);
  pbdam::tools::CommandStatus status;
  pbdam::tools::addDemCommands(app, status);
  pbdam::tools::addDevicesCommand(app, status);
  pbdam::tools::addBuildCommand(app, status);
  pbdam::tools::addDatasetCommands(app, status);
  pbdam::tools::addRenderCommand(app, status);
  pbdam::tools::addHeightCommand(app, status);
  pbdam::tools::addPathCommands(app, status);
  pbdam::tools::addQueryCommands(app, status);
  pbdam::tools::addBenchCommand(app, status);
  pbdam::tools::addServeCommand(app, status);
  pbdam::tools::addFlyCommand(app, status);
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    // One line naming what was wrong, like every other bad-input report (from one MPI rank).
    if (!pbdam::tools::isMpiRankOtherThanZero()) {
      std::cerr << "pbdam: " << e.what() << " (run with --help for usage)\n";
    }
    return pbdam::tools::kExitBadInput;
  }
  return status.exitCode;
}

}  // namespace

int main(int argc, char** argv) {
  // Mapped bytes read in place (the builder's and verify's scratch and checkpoint files) that
  // become unreadable end the command with a line naming the file and offset and exit code 2,
  // not a SIGBUS; reads of datasets go through guarded copies and are errors of their own.
  pbdam::formats::reportUnreadableMappingsAndExit(pbdam::tools::kExitBadInput);
  // Commands report bad input as results; an exception reaching here is a bug or an exhausted
  // resource (std::bad_alloc): one line and exit code 1 rather than std::terminate's abort.
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pbdam: internal error: %s\n", e.what());
  } catch (...) {
    std::fprintf(stderr, "pbdam: internal error: unknown exception\n");
  }
  return pbdam::tools::kExitFailure;
}
