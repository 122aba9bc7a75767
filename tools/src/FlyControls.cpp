#include "FlyControls.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>
#include <utility>

#include "pbdam/formats/NumberList.h"

using namespace pbdam::formats;
using pbdam::runtime::CameraPose;

namespace pbdam::tools {
namespace {

constexpr double kDegrees = 180.0 / std::numbers::pi;
constexpr double kTurnDegreesPerSecond = 60.0;
constexpr double kDragDegreesPerPixel = 0.2;
constexpr double kHeightFactorPerSecond = 1.8;  // Q/E
constexpr double kHeightFactorPerClick = 1.15;  // the wheel
constexpr double kMinPitch = -90.0;
constexpr double kMaxPitch = 30.0;

constexpr std::array<std::pair<std::string_view, FlyKey>, 23> kKeyNames = {{
    {"w", FlyKey::W},
    {"a", FlyKey::A},
    {"s", FlyKey::S},
    {"d", FlyKey::D},
    {"q", FlyKey::Q},
    {"e", FlyKey::E},
    {"r", FlyKey::R},
    {"f", FlyKey::F},
    {"up", FlyKey::Up},
    {"down", FlyKey::Down},
    {"left", FlyKey::Left},
    {"right", FlyKey::Right},
    {"m", FlyKey::M},
    {"v", FlyKey::V},
    {"h", FlyKey::H},
    {"p", FlyKey::P},
    {"g", FlyKey::G},
    {"f1", FlyKey::F1},
    {"enter", FlyKey::Enter},
    {"escape", FlyKey::Escape},
    {"backspace", FlyKey::Backspace},
    {"[", FlyKey::BracketLeft},
    {"]", FlyKey::BracketRight},
}};

double wrapLongitude(double lon) { return std::remainder(lon, 360.0); }
double wrapHeading(double heading) {
  const double h = std::fmod(heading, 360.0);
  return h < 0.0 ? h + 360.0 : h;
}

bool isFlightKey(FlyKey key) {
  switch (key) {
    case FlyKey::W:
    case FlyKey::A:
    case FlyKey::S:
    case FlyKey::D:
    case FlyKey::Q:
    case FlyKey::E:
    case FlyKey::R:
    case FlyKey::F:
    case FlyKey::Up:
    case FlyKey::Down:
    case FlyKey::Left:
    case FlyKey::Right:
      return true;
    default:
      return false;
  }
}

}  // namespace

std::optional<FlyKey> parseFlyKey(std::string_view name) {
  for (const auto& [text, key] : kKeyNames) {
    if (text == name) return key;
  }
  return std::nullopt;
}

FlyControls::FlyControls(const CameraPose& start, double equatorialRadiusMeters, GroundQuery ground,
                         double clearanceMeters)
    : pose_(start),
      radius_(equatorialRadiusMeters),
      groundQuery_(std::move(ground)),
      clearance_(clearanceMeters) {
  refreshGround();
  keepAboveGround();
}

void FlyControls::refreshGround() {
  if (!groundQuery_) return;
  if (const std::optional<double> h = groundQuery_(pose_.latDegrees, pose_.lonDegrees)) {
    ground_ = *h;
  }
}

void FlyControls::keepAboveGround() {
  pose_.altitudeMeters = std::max(pose_.altitudeMeters, ground_ + clearance_);
}

void FlyControls::setHeightAboveGround(double meters) {
  pose_.altitudeMeters = ground_ + std::clamp(meters, clearance_, 20.0 * radius_);
}

void FlyControls::moveOverGround(double forwardMeters, double rightMeters) {
  const double h = pose_.headingDegrees / kDegrees;
  const double north = forwardMeters * std::cos(h) - rightMeters * std::sin(h);
  const double east = forwardMeters * std::sin(h) + rightMeters * std::cos(h);
  pose_.latDegrees = std::clamp(pose_.latDegrees + north / radius_ * kDegrees, -89.9, 89.9);
  const double c = std::max(std::cos(pose_.latDegrees / kDegrees), 0.01);
  pose_.lonDegrees = wrapLongitude(pose_.lonDegrees + east / (radius_ * c) * kDegrees);
  // The height above the ground is kept as the ground changes under the camera.
  const double height = heightAboveGround();
  refreshGround();
  setHeightAboveGround(height);
}

void FlyControls::press(FlyKey key) {
  if (typing) {
    if (key == FlyKey::Escape) {
      typing = false;
      typed.clear();
    } else if (key == FlyKey::Backspace && !typed.empty()) {
      typed.pop_back();
    } else if (key == FlyKey::Enter) {
      typing = false;
      std::vector<double> latLon;
      if (!parseNumberList(typed, 2, latLon)) {
        message = "go to: expected LAT,LON in degrees, got \"" + typed + "\"";
      } else if (auto r = goTo(latLon[0], latLon[1]); !r) {
        message = "go to: " + r.error().message;
      } else {
        message.clear();
      }
      typed.clear();
    }
    return;
  }
  if (isFlightKey(key)) {
    held_.insert(key);
    return;
  }
  switch (key) {
    case FlyKey::M:
      morph = !morph;
      break;
    case FlyKey::V:
      viewshed = !viewshed;
      break;
    case FlyKey::H:
      hud = !hud;
      break;
    case FlyKey::F1:
      help = !help;
      break;
    case FlyKey::P:
      ++screenshotsWanted;
      break;
    case FlyKey::BracketLeft:
      sunHours -= 1.0;
      break;
    case FlyKey::BracketRight:
      sunHours += 1.0;
      break;
    case FlyKey::G:
      typing = true;
      typed.clear();
      message.clear();
      break;
    default:
      break;
  }
}

void FlyControls::release(FlyKey key) { held_.erase(key); }

void FlyControls::type(std::string_view text) {
  if (!typing) return;
  for (const char c : text) {
    if ((c >= '0' && c <= '9') || c == '.' || c == ',' || c == '-' || c == '+') typed += c;
  }
}

void FlyControls::drag(double dxPixels, double dyPixels) {
  pose_.headingDegrees = wrapHeading(pose_.headingDegrees + dxPixels * kDragDegreesPerPixel);
  pose_.pitchDegrees =
      std::clamp(pose_.pitchDegrees - dyPixels * kDragDegreesPerPixel, kMinPitch, kMaxPitch);
}

void FlyControls::wheel(double clicks) {
  setHeightAboveGround(heightAboveGround() * std::pow(kHeightFactorPerClick, -clicks));
}

void FlyControls::update(double seconds) {
  if (held_.empty() || !(seconds > 0.0)) {
    keepAboveGround();
    return;
  }
  const auto held = [&](FlyKey key) { return held_.count(key) > 0; };
  const double speed = std::max(heightAboveGround(), 10.0) * 0.8;  // ground metres per second
  const double turn = kTurnDegreesPerSecond * seconds;
  double forward = 0.0;
  double right = 0.0;
  if (held(FlyKey::W) || held(FlyKey::Up)) forward += speed * seconds;
  if (held(FlyKey::S) || held(FlyKey::Down)) forward -= speed * seconds;
  if (held(FlyKey::D)) right += speed * seconds;
  if (held(FlyKey::A)) right -= speed * seconds;
  if (forward != 0.0 || right != 0.0) moveOverGround(forward, right);
  if (held(FlyKey::Left)) pose_.headingDegrees = wrapHeading(pose_.headingDegrees - turn);
  if (held(FlyKey::Right)) pose_.headingDegrees = wrapHeading(pose_.headingDegrees + turn);
  if (held(FlyKey::E)) {
    setHeightAboveGround(heightAboveGround() * std::pow(kHeightFactorPerSecond, seconds));
  }
  if (held(FlyKey::Q)) {
    setHeightAboveGround(heightAboveGround() / std::pow(kHeightFactorPerSecond, seconds));
  }
  if (held(FlyKey::R)) pose_.pitchDegrees = std::min(pose_.pitchDegrees + turn, kMaxPitch);
  if (held(FlyKey::F)) pose_.pitchDegrees = std::max(pose_.pitchDegrees - turn, kMinPitch);
  keepAboveGround();
}

Result<void> FlyControls::goTo(double latDegrees, double lonDegrees) {
  if (!std::isfinite(latDegrees) || !std::isfinite(lonDegrees) || std::abs(latDegrees) > 90.0 ||
      std::abs(lonDegrees) > 360.0) {
    return invalidArgument("latitude must be in [-90, 90] and longitude in [-360, 360]");
  }
  const double height = heightAboveGround();
  pose_.latDegrees = latDegrees;
  pose_.lonDegrees = wrapLongitude(lonDegrees);
  refreshGround();
  setHeightAboveGround(height);
  return {};
}

void FlyControls::setPose(const CameraPose& pose) {
  pose_ = pose;
  refreshGround();
  keepAboveGround();
}

Result<std::vector<FlyScriptEvent>> parseFlyScript(std::string_view text, std::string_view name) {
  std::vector<FlyScriptEvent> events;
  std::istringstream lines{std::string(text)};
  std::string line;
  int number = 0;
  double last = 0.0;
  while (std::getline(lines, line)) {
    ++number;
    const auto fail = [&](const std::string& what) {
      return invalidArgument(std::string(name) + ":" + std::to_string(number) + ": " + what);
    };
    if (const std::size_t hash = line.find('#'); hash != std::string::npos) line.resize(hash);
    std::istringstream words(line);
    std::string time;
    if (!(words >> time)) continue;
    std::vector<double> t;
    if (!parseNumberList(time, 1, t) || t[0] < 0.0) {
      return fail("expected a time in seconds >= 0, got \"" + time + "\"");
    }
    if (t[0] < last) return fail("times must not decrease");
    last = t[0];
    FlyScriptEvent event;
    event.tSeconds = t[0];
    std::string action;
    words >> action;
    std::vector<std::string> args;
    for (std::string word; words >> word;) args.push_back(word);
    const auto numbers = [&](std::size_t count) -> std::optional<std::vector<double>> {
      if (args.size() != count) return std::nullopt;
      std::vector<double> values;
      for (const std::string& a : args) {
        std::vector<double> one;
        if (!parseNumberList(a, 1, one)) return std::nullopt;
        values.push_back(one[0]);
      }
      return values;
    };
    if (action == "key") {
      if (args.empty() || args.size() > 2) return fail("expected key NAME [down|up]");
      const std::optional<FlyKey> key = parseFlyKey(args[0]);
      if (!key) return fail("unknown key \"" + args[0] + "\"");
      event.key = *key;
      if (args.size() == 1) {
        event.kind = FlyScriptEvent::Kind::KeyTap;
      } else if (args[1] == "down") {
        event.kind = FlyScriptEvent::Kind::KeyDown;
      } else if (args[1] == "up") {
        event.kind = FlyScriptEvent::Kind::KeyUp;
      } else {
        return fail("expected down or up after the key, got \"" + args[1] + "\"");
      }
    } else if (action == "drag") {
      const auto v = numbers(2);
      if (!v) return fail("expected drag DX DY (pixels)");
      event.kind = FlyScriptEvent::Kind::Drag;
      event.x = (*v)[0];
      event.y = (*v)[1];
    } else if (action == "wheel") {
      const auto v = numbers(1);
      if (!v) return fail("expected wheel CLICKS");
      event.kind = FlyScriptEvent::Kind::Wheel;
      event.x = (*v)[0];
    } else if (action == "type") {
      if (args.size() != 1) return fail("expected type TEXT (one word)");
      event.kind = FlyScriptEvent::Kind::Type;
      event.text = args[0];
    } else if (action == "resize") {
      const auto v = numbers(2);
      if (!v || (*v)[0] < 1.0 || (*v)[1] < 1.0 || (*v)[0] > 16384.0 || (*v)[1] > 16384.0) {
        return fail("expected resize WIDTH HEIGHT (1 to 16384 pixels)");
      }
      event.kind = FlyScriptEvent::Kind::Resize;
      event.x = (*v)[0];
      event.y = (*v)[1];
    } else if (action == "close") {
      if (!args.empty()) return fail("close takes no arguments");
      event.kind = FlyScriptEvent::Kind::Close;
    } else {
      return fail("unknown action \"" + action + "\" (key, drag, wheel, type, resize or close)");
    }
    events.push_back(std::move(event));
  }
  return events;
}

Result<std::vector<FlyScriptEvent>> readFlyScript(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return makeError(ErrorCode::NotFound, path + ": cannot open the script");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) return makeError(ErrorCode::IoError, path + ": read failed");
  return parseFlyScript(text.str(), path);
}

}  // namespace pbdam::tools
