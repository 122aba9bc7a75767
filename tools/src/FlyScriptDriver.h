// The input of `pbdam fly` that no person gives: the timed events of a `--script` file (tests)
// and the camera path of `--replay`, applied to the controls (FlyControls.h) as the flight's
// clock runs. Apart from any window: a resize event calls back into the window's owner.
// Thread-safety: none; the window's thread owns it.
#pragma once

#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "FlyControls.h"
#include "pbdam/formats/CameraPath.h"
#include "pbdam/formats/Result.h"
#include "pbdam/runtime/Camera.h"

namespace pbdam::tools {

class FlyScriptDriver final {
 public:
  /// Reads the script at `scriptPath` and then the camera path at `replayPath`; an empty path
  /// gives none. Errors as readFlyScript and formats::readCameraPath, the script's first.
  static formats::Result<FlyScriptDriver> load(const std::string& scriptPath,
                                               const std::string& replayPath);

  /// The replay's pose at its start; nullopt without a replay.
  std::optional<runtime::CameraPose> replayStart() const;

  /// Applies the script's events due by `t` seconds, each after `advanceTo(its time)` has moved
  /// the controls up to it; a resize event calls `resizeWindow(width, height)`. Returns false
  /// once a close event was applied.
  bool applyScript(double t, FlyControls& controls,
                   const std::function<void(int, int)>& resizeWindow,
                   const std::function<void(double)>& advanceTo);

  /// Sets the controls to the replay's pose at `t` seconds (linear between rows, heading the
  /// short way). Returns false once `t` is past the replay's end; true without a replay.
  bool applyReplay(double t, FlyControls& controls) const;

 private:
  std::vector<FlyScriptEvent> events_;
  std::size_t next_ = 0;  ///< the first event not applied yet
  std::vector<formats::CameraPathPoint> replay_;
};

}  // namespace pbdam::tools
