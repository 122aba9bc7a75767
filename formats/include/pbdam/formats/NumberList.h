// Parsing of comma-separated numbers given on command lines and in URLs ("LAT,LON", "W,H",
// "S,W,N,E"): strict, finite, exactly the expected count.
#pragma once

#include <cstddef>
#include <string_view>
#include <vector>

namespace pbdam::formats {

/// Parses `text` as exactly `count` comma-separated finite decimal numbers (no spaces, no
/// trailing characters). Returns false and leaves `out` unspecified on any deviation.
bool parseNumberList(std::string_view text, std::size_t count, std::vector<double>& out);

}  // namespace pbdam::formats
