// The text of a viewshed request in one option or parameter, `LAT,LON,H[,RADIUS_M]`
// (`pbdam render --viewshed`, `/frame?viewshed=`). Header-only: the server's request parsing
// (and its fuzz target) use it without the viewshed's GPU and GDAL code.
#pragma once

#include <string>
#include <vector>

#include "pbdam/formats/NumberList.h"
#include "pbdam/formats/Result.h"
#include "pbdam/runtime/Viewshed.h"

namespace pbdam::tools {

/// InvalidArgument naming `option` and the text unless it is three or four numbers; the numbers
/// themselves are checked by runtime::viewshedGrid.
inline formats::Result<runtime::ViewshedRequest> parseViewshedSpec(const std::string& option,
                                                                   const std::string& text) {
  std::vector<double> v;
  if (!formats::parseNumberList(text, 3, v) && !formats::parseNumberList(text, 4, v)) {
    return formats::makeError(
        formats::ErrorCode::InvalidArgument,
        option + " '" + text + "': expected LAT,LON,HEIGHT_ABOVE_GROUND_M[,RADIUS_M]");
  }
  runtime::ViewshedRequest request{v[0], v[1], v[2], {}, {}};
  if (v.size() == 4) request.radiusMeters = v[3];
  return request;
}

}  // namespace pbdam::tools
