// The script and replay input of `pbdam fly` (FlyScriptDriver.h).
#include "FlyScriptDriver.h"

#include <algorithm>
#include <cmath>
#include <utility>

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::tools {
namespace {

/// The pose along a recorded path at `t` seconds (linear between rows; heading the short way).
CameraPose replayPoseAt(const std::vector<CameraPathPoint>& path, double t) {
  const auto pose = [](const CameraPathPoint& p) {
    return CameraPose{p.latDegrees,     p.lonDegrees,   p.altitudeMeters,
                      p.headingDegrees, p.pitchDegrees, p.rollDegrees};
  };
  if (t <= path.front().tSeconds) return pose(path.front());
  if (t >= path.back().tSeconds) return pose(path.back());
  const auto next =
      std::upper_bound(path.begin(), path.end(), t,
                       [](double v, const CameraPathPoint& p) { return v < p.tSeconds; });
  const CameraPathPoint& b = *next;
  const CameraPathPoint& a = *(next - 1);
  const double s = (t - a.tSeconds) / (b.tSeconds - a.tSeconds);
  const auto mix = [s](double x, double y) { return x + (y - x) * s; };
  const auto mixAngle = [s](double x, double y) { return x + std::remainder(y - x, 360.0) * s; };
  return CameraPose{
      mix(a.latDegrees, b.latDegrees),         mixAngle(a.lonDegrees, b.lonDegrees),
      mix(a.altitudeMeters, b.altitudeMeters), mixAngle(a.headingDegrees, b.headingDegrees),
      mix(a.pitchDegrees, b.pitchDegrees),     mixAngle(a.rollDegrees, b.rollDegrees)};
}

}  // namespace

Result<FlyScriptDriver> FlyScriptDriver::load(const std::string& scriptPath,
                                              const std::string& replayPath) {
  FlyScriptDriver driver;
  if (!scriptPath.empty()) {
    auto events = readFlyScript(scriptPath);
    if (!events) return std::move(events).error();
    driver.events_ = std::move(*events);
  }
  if (!replayPath.empty()) {
    auto points = readCameraPath(replayPath);
    if (!points) return std::move(points).error();
    driver.replay_ = std::move(*points);
  }
  return driver;
}

std::optional<CameraPose> FlyScriptDriver::replayStart() const {
  if (replay_.empty()) return std::nullopt;
  return replayPoseAt(replay_, 0.0);
}

bool FlyScriptDriver::applyScript(double t, FlyControls& controls,
                                  const std::function<void(int, int)>& resizeWindow,
                                  const std::function<void(double)>& advanceTo) {
  bool open = true;
  while (next_ < events_.size() && events_[next_].tSeconds <= t) {
    const FlyScriptEvent& e = events_[next_++];
    // The controls move up to the event's own time first: a key held from 0.5 s to 2.5 s
    // moves the camera for 2 s however few frames fall between.
    advanceTo(e.tSeconds);
    switch (e.kind) {
      case FlyScriptEvent::Kind::KeyDown:
        controls.press(e.key);
        break;
      case FlyScriptEvent::Kind::KeyUp:
        controls.release(e.key);
        break;
      case FlyScriptEvent::Kind::KeyTap:
        controls.press(e.key);
        controls.release(e.key);
        break;
      case FlyScriptEvent::Kind::Drag:
        controls.drag(e.x, e.y);
        break;
      case FlyScriptEvent::Kind::Wheel:
        controls.wheel(e.x);
        break;
      case FlyScriptEvent::Kind::Type:
        controls.type(e.text);
        break;
      case FlyScriptEvent::Kind::Resize:
        resizeWindow(static_cast<int>(e.x), static_cast<int>(e.y));
        break;
      case FlyScriptEvent::Kind::Close:
        open = false;
        break;
    }
  }
  return open;
}

bool FlyScriptDriver::applyReplay(double t, FlyControls& controls) const {
  if (replay_.empty()) return true;
  const bool within = !(t > replay_.back().tSeconds);
  controls.setPose(replayPoseAt(replay_, t));
  return within;
}

}  // namespace pbdam::tools
