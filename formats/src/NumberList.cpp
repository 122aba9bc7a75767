// Strict comma-separated number parsing (NumberList.h).
#include "pbdam/formats/NumberList.h"

#include <cmath>
#include <cstdlib>
#include <string>

namespace pbdam::formats {

bool parseNumberList(std::string_view text, std::size_t count, std::vector<double>& out) {
  out.clear();
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = text.find(',', start);
    const std::string part(text.substr(
        start, comma == std::string_view::npos ? std::string_view::npos : comma - start));
    char* end = nullptr;
    const double v = std::strtod(part.c_str(), &end);
    if (part.empty() || part.front() == ' ' || end != part.c_str() + part.size() ||
        !std::isfinite(v)) {
      return false;
    }
    out.push_back(v);
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return out.size() == count;
}

}  // namespace pbdam::formats
