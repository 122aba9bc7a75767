// The controls of `pbdam fly`, apart from any window: keys held and tapped, mouse drags and the
// wheel turn into a camera pose over the planet, as in the web viewer of `pbdam serve`
// (WASD/arrows fly and turn, drag looks, wheel or Q/E change the height, R/F pitch, M morph,
// V viewshed) plus G to type a place to fly to, P for a screenshot, H for the heads-up display
// and F1 for help. Speed scales with the height above the ground, and the camera never goes
// below the ground plus a clearance. Also the script of timed events (`--script`) that drives
// the same controls in tests. Thread-safety: none; the window's thread owns them.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "pbdam/formats/Result.h"
#include "pbdam/runtime/Camera.h"

namespace pbdam::tools {

/// The keys the controls know. Flight keys act while held; the others on a press.
enum class FlyKey {
  W,
  A,
  S,
  D,
  Q,
  E,
  R,
  F,
  Up,
  Down,
  Left,
  Right,
  M,
  V,
  H,
  P,
  G,
  F1,
  Enter,
  Escape,
  Backspace,
  BracketLeft,   ///< the sun's time an hour back
  BracketRight,  ///< the sun's time an hour on
};

/// "w", "up", "f1", "enter", "escape", "backspace", "[", "]"... (lower case); nullopt for other
/// names.
std::optional<FlyKey> parseFlyKey(std::string_view name);

/// The camera and the toggles, moved by input and time.
class FlyControls final {
 public:
  /// The surface height (metres above the reference surface) at a geodetic position; nullopt
  /// where it is unknown (then the last known height is kept).
  using GroundQuery = std::function<std::optional<double>(double latDegrees, double lonDegrees)>;

  /// Starts at `start` over a planet of `equatorialRadiusMeters`, asking `ground` for the
  /// surface height. The camera never goes below the ground plus `clearanceMeters`.
  FlyControls(const runtime::CameraPose& start, double equatorialRadiusMeters, GroundQuery ground,
              double clearanceMeters = 2.0);

  void press(FlyKey key);
  void release(FlyKey key);
  /// Characters typed (G's place entry; ignored outside it).
  void type(std::string_view text);
  /// A drag by (dx, dy) pixels: heading and pitch, 0.2 degrees a pixel.
  void drag(double dxPixels, double dyPixels);
  /// Wheel clicks (positive: away from the user = down towards the ground).
  void wheel(double clicks);
  /// Advances the held keys by `seconds`.
  void update(double seconds);
  /// Flies to (lat, lon) at the present height above the ground.
  formats::Result<void> goTo(double latDegrees, double lonDegrees);

  const runtime::CameraPose& pose() const noexcept { return pose_; }
  /// Sets the pose (replay), lifted above the ground plus the clearance.
  void setPose(const runtime::CameraPose& pose);
  double groundMeters() const noexcept { return ground_; }
  double heightAboveGround() const noexcept { return pose_.altitudeMeters - ground_; }

  bool morph = true;
  bool viewshed = false;
  bool hud = true;
  bool help = false;
  /// Hours the sun's time is moved from --time's ([ and ]).
  double sunHours = 0.0;
  /// Screenshots asked for and not yet taken (P).
  int screenshotsWanted = 0;
  /// G's place entry: active, the text so far, and the last message (a bad entry).
  bool typing = false;
  std::string typed;
  std::string message;

 private:
  void refreshGround();
  void keepAboveGround();
  void moveOverGround(double forwardMeters, double rightMeters);
  void setHeightAboveGround(double meters);

  runtime::CameraPose pose_;
  double radius_;
  GroundQuery groundQuery_;
  double clearance_;
  double ground_ = 0.0;
  std::set<FlyKey> held_;
};

/// One event of a `--script` file, at `tSeconds` after the window opened.
struct FlyScriptEvent final {
  enum class Kind { KeyDown, KeyUp, KeyTap, Drag, Wheel, Type, Resize, Close };
  double tSeconds = 0.0;
  Kind kind = Kind::KeyTap;
  FlyKey key = FlyKey::W;
  double x = 0.0;  ///< drag dx, wheel clicks, resize width
  double y = 0.0;  ///< drag dy, resize height
  std::string text;
};

/// Parses a script: one event a line, `T ACTION ARGS`, T in seconds (not decreasing), '#'
/// comments and blank lines skipped. Actions: `key NAME [down|up]` (no third word: a tap),
/// `drag DX DY`, `wheel CLICKS`, `type TEXT`, `resize WIDTH HEIGHT`, `close`. Errors are
/// InvalidArgument "<name>:<line>: <what>".
formats::Result<std::vector<FlyScriptEvent>> parseFlyScript(std::string_view text,
                                                            std::string_view name);

/// Reads and parses a script file (NotFound, IoError, or parseFlyScript's errors).
formats::Result<std::vector<FlyScriptEvent>> readFlyScript(const std::string& path);

}  // namespace pbdam::tools
