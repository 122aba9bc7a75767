// Parsing and spelling of the frame loop's modes (FrameModes.h).
#include "pbdam/gpu/FrameModes.h"

#include <string>

using namespace pbdam::formats;

namespace pbdam::gpu {
namespace {

Error unexpected(std::string_view option, std::string_view spelled, std::string_view expected) {
  return invalidArgument(std::string(option) + " '" + std::string(spelled) + "': expected " +
                         std::string(expected));
}

}  // namespace

Result<StreamingMode> parseStreamingMode(std::string_view spelled) {
  if (spelled == "paging") return StreamingMode::Paging;
  if (spelled == "no-stall") return StreamingMode::NoStall;
  return unexpected("--mode", spelled, "paging or no-stall");
}

Result<CutSelection> parseCutSelection(std::string_view spelled) {
  if (spelled == "cpu") return CutSelection::Cpu;
  if (spelled == "gpu") return CutSelection::Gpu;
  return unexpected("--selection", spelled, "cpu or gpu");
}

Result<DrawList> parseDrawList(std::string_view spelled) {
  if (spelled == "readback") return DrawList::Readback;
  if (spelled == "indirect") return DrawList::Indirect;
  return unexpected("--draws", spelled, "readback or indirect");
}

Result<RunChoice> parseRunChoice(std::string_view option, std::string_view spelled) {
  if (spelled == "off") return RunChoice::Off;
  if (spelled == "on") return RunChoice::On;
  if (spelled == "both") return RunChoice::Both;
  return unexpected(option, spelled, "on, off or both");
}

Result<bool> parseOnOff(std::string_view option, std::string_view spelled) {
  if (spelled == "on") return true;
  if (spelled == "off") return false;
  return unexpected(option, spelled, "on or off");
}

const char* toString(StreamingMode mode) noexcept {
  return mode == StreamingMode::NoStall ? "no-stall" : "paging";
}

const char* toString(CutSelection selection) noexcept {
  return selection == CutSelection::Gpu ? "gpu" : "cpu";
}

const char* toString(DrawList draws) noexcept {
  return draws == DrawList::Indirect ? "indirect" : "readback";
}

const char* toString(RunChoice choice) noexcept {
  switch (choice) {
    case RunChoice::Off:
      return "off";
    case RunChoice::On:
      return "on";
    case RunChoice::Both:
      return "both";
  }
  return "both";
}

const char* onOff(bool on) noexcept { return on ? "on" : "off"; }

}  // namespace pbdam::gpu
