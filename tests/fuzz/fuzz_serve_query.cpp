// libFuzzer target for `pbdam serve`'s request parsing (tools/src/ServeRequest.cpp): the input
// is a request target ("/frame?lat=1&lon=2&alt=3"), split and percent-decoded by the same
// cpp-httplib functions the server runs (path before '?', then the query's name=value pairs),
// then routed as the server routes it: /frame to parseFrameQuery on Mars and the Earth, /height
// to parseHeightQuery, /los and /viewshed to theirs, any other path to expectNoParams. A parse must
// either succeed with values in the documented ranges or return InvalidArgument with a message.
// Seeds: valid and invalid targets of every endpoint (tests/fuzz/corpus/serve_query).
#include <httplib.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include "ServeRequest.h"

namespace {

using namespace pbdam;

void checkError(const formats::Error& error) {
  if (error.code != formats::ErrorCode::InvalidArgument || error.message.empty()) {
    __builtin_trap();
  }
}

void frame(const tools::QueryParams& params, const runtime::Planet& planet) {
  auto q = tools::parseFrameQuery(params, planet);
  if (!q) return checkError(q.error());
  const auto& r = q->request;
  if (r.viewport.width < 1 || r.viewport.width > tools::kMaxFrameSidePixels ||
      r.viewport.height < 1 || r.viewport.height > tools::kMaxFrameSidePixels) {
    __builtin_trap();
  }
  if (!(r.tolerancePixels >= tools::kMinTolerancePixels &&
        r.tolerancePixels <= tools::kMaxTolerancePixels)) {
    __builtin_trap();
  }
  if (!std::isfinite(r.pose.latDegrees) || !std::isfinite(r.pose.altitudeMeters)) {
    __builtin_trap();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string target(reinterpret_cast<const char*>(data), size);
  const std::size_t question = target.find('?');
  const std::string path = httplib::detail::decode_url(target.substr(0, question), false);
  tools::QueryParams params;
  if (question != std::string::npos) {
    httplib::detail::parse_query_text(target.substr(question + 1), params);
  }
  if (path == "/frame") {
    frame(params, runtime::Planet::mars());
    frame(params, runtime::Planet::earthWgs84());
  } else if (path == "/height") {
    auto h = tools::parseHeightQuery(params);
    if (!h) {
      checkError(h.error());
    } else if (!(std::fabs(h->latDegrees) <= 90.0 && std::fabs(h->lonDegrees) <= 360.0)) {
      __builtin_trap();
    }
  } else if (path == "/los") {
    auto q = tools::parseLosQuery(params);
    if (!q) checkError(q.error());
  } else if (path == "/viewshed") {
    auto q = tools::parseViewshedQuery(params);
    if (!q) {
      checkError(q.error());
    } else if ((q->request.radiusMeters && !(*q->request.radiusMeters > 0.0)) ||
               (q->request.cellMeters && !(*q->request.cellMeters > 0.0))) {
      __builtin_trap();
    }
  } else if (auto none = tools::expectNoParams(params); !none) {
    checkError(none.error());
  }
  return 0;
}
