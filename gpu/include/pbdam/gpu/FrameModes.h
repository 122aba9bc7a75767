// The frame loop's modes of `pbdam bench` and `pbdam render` as types: each option is parsed once,
// where the command checks its options, and the loop and the reports use the enums; reports write
// them back with the command line's spelling (toString). Thread-safety: pure functions.
#pragma once

#include <string_view>

#include "pbdam/formats/Result.h"

namespace pbdam::gpu {

/// bench --mode: what a frame does about pages that are not resident.
enum class StreamingMode {
  Paging,   ///< "paging": they fault in on the render thread
  NoStall,  ///< "no-stall": the finest resident conforming cut is drawn instead
};

/// --selection: where a frame's cut is selected.
enum class CutSelection {
  Cpu,  ///< "cpu": on the host
  Gpu,  ///< "gpu": by the selection's compute passes on the device
};

/// bench --draws: who makes the draw list of a cut selected on the device.
enum class DrawList {
  Readback,  ///< "readback": the host, from the cut read back
  Indirect,  ///< "indirect": the device, drawn with one indirect draw
};

/// bench --prefetch and --morph: the runs to make with the setting on, off, or one of each.
enum class RunChoice {
  Off,   ///< "off"
  On,    ///< "on"
  Both,  ///< "both": off, then on
};

/// The mode `spelled` names. InvalidArgument "--mode 'X': expected paging or no-stall".
formats::Result<StreamingMode> parseStreamingMode(std::string_view spelled);
/// InvalidArgument "--selection 'X': expected cpu or gpu".
formats::Result<CutSelection> parseCutSelection(std::string_view spelled);
/// InvalidArgument "--draws 'X': expected readback or indirect".
formats::Result<DrawList> parseDrawList(std::string_view spelled);
/// on, off or both; InvalidArgument "OPTION 'X': expected on, off or both".
formats::Result<RunChoice> parseRunChoice(std::string_view option, std::string_view spelled);
/// on (true) or off (false); InvalidArgument "OPTION 'X': expected on or off".
formats::Result<bool> parseOnOff(std::string_view option, std::string_view spelled);

/// The command line's spelling of each value ("paging", "no-stall", "cpu", "gpu", "readback",
/// "indirect", "off", "on", "both"): what frames.csv and summary.json write.
/// @{
const char* toString(StreamingMode mode) noexcept;
const char* toString(CutSelection selection) noexcept;
const char* toString(DrawList draws) noexcept;
const char* toString(RunChoice choice) noexcept;
/// @}
/// "on" or "off".
const char* onOff(bool on) noexcept;

/// Whether `choice` makes the run whose setting is `on`.
constexpr bool includes(RunChoice choice, bool on) noexcept {
  return choice == RunChoice::Both || (choice == RunChoice::On) == on;
}

}  // namespace pbdam::gpu
