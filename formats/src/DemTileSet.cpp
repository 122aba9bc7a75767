// Sets of DEM tiles: expansion, probing and grouping into surfaces (DemTileSet.h; the mosaic
// read and the probe itself are in DemReader.cpp, beside the reader they share).
#include "pbdam/formats/DemTileSet.h"

#include <glob.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <numeric>
#include <string_view>

namespace pbdam::formats {
namespace {

namespace fs = std::filesystem;

std::string lowerCase(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

/// Files that sit beside rasters and are not rasters themselves.
bool isSideFile(const fs::path& file) {
  const std::string name = lowerCase(file.filename().string());
  if (name.empty() || name.front() == '.') return true;
  static constexpr std::string_view kSuffixes[] = {
      ".aux.xml", ".xml", ".prj",  ".tfw", ".tifw", ".wld", ".hgtw", ".txt",    ".md",  ".json",
      ".ovr",     ".msk", ".html", ".htm", ".pdf",  ".md5", ".sha1", ".sha256", ".sum", ".lbl",
      ".cpg",     ".dbf", ".shp",  ".shx", ".qix",  ".hdr", ".stx",  ".csv",    ".log"};
  return std::any_of(std::begin(kSuffixes), std::end(kSuffixes), [&](std::string_view s) {
    return name.size() > s.size() && name.compare(name.size() - s.size(), s.size(), s) == 0;
  });
}

bool hasGlobCharacter(const std::string& text) {
  return text.find_first_of("*?[") != std::string::npos;
}

/// Union-find over tile indices.
struct Components final {
  std::vector<std::size_t> parent;
  explicit Components(std::size_t n) : parent(n) {
    std::iota(parent.begin(), parent.end(), std::size_t{0});
  }
  std::size_t find(std::size_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  }
  void join(std::size_t a, std::size_t b) {
    a = find(a);
    b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
};

bool sameSpacing(double a, double b) { return std::abs(a - b) <= 1e-9 * std::abs(a); }

/// Whether b's grid lines fall on a's (to a hundredth of a sample).
bool aligned(double originA, double originB, double spacing) {
  const double steps = (originB - originA) / spacing;
  return std::abs(steps - std::round(steps)) <= 0.01;
}

}  // namespace

bool namesDemSet(const fs::path& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) return true;
  return !fs::exists(path, ec) && hasGlobCharacter(path.string());
}

Result<std::vector<fs::path>> expandDemSet(const fs::path& path) {
  std::error_code ec;
  std::vector<fs::path> files;
  if (fs::is_directory(path, ec)) {
    fs::directory_iterator it(path, ec);
    if (ec) {
      return makeError(ErrorCode::IoError, path.string() + ": cannot list (" + ec.message() + ")");
    }
    for (const fs::directory_entry& entry : it) {
      if (entry.is_regular_file(ec) && !isSideFile(entry.path())) files.push_back(entry.path());
    }
    if (files.empty()) {
      return invalidArgument(path.string() +
                             ": the directory holds no tiles (side files such as .prj, .aux.xml "
                             "and .txt do not count)");
    }
  } else if (!fs::exists(path, ec) && hasGlobCharacter(path.string())) {
    glob_t matches{};
    const int status = ::glob(path.c_str(), 0, nullptr, &matches);
    for (std::size_t i = 0; status == 0 && i < matches.gl_pathc; ++i) {
      const fs::path match = matches.gl_pathv[i];
      if (fs::is_regular_file(match, ec) && !isSideFile(match)) files.push_back(match);
    }
    ::globfree(&matches);
    if (files.empty()) {
      return makeError(ErrorCode::NotFound, path.string() + ": the pattern matches no tiles");
    }
  } else {
    files.push_back(path);
  }
  std::sort(files.begin(), files.end());
  return files;
}

Result<std::vector<DemTileProbe>> probeDemTiles(const std::vector<fs::path>& paths) {
  std::vector<DemTileProbe> tiles;
  tiles.reserve(paths.size());
  const DemTileProbe* named = nullptr;  // the first tile whose CRS names its body
  for (const fs::path& path : paths) {
    auto probe = probeDemTile(path);
    if (!probe) return std::move(probe).error();
    tiles.push_back(std::move(probe).value());
    const DemTileProbe& tile = tiles.back();
    if (tile.body.empty()) continue;
    if (named == nullptr) {
      named = &tiles.back();
      continue;
    }
    if (tile.body != named->body) {
      return invalidArgument(tile.path.string() + ": its CRS is on " + tile.body + ", but " +
                             named->path.filename().string() + " of the same set is on " +
                             named->body + ": the tiles of a set must be of one body");
    }
  }
  return tiles;
}

std::vector<std::vector<std::size_t>> groupDemTiles(const std::vector<DemTileProbe>& tiles,
                                                    const std::vector<int>& keys) {
  const std::size_t n = tiles.size();
  const auto key = [&](std::size_t i) { return keys.empty() ? 0 : keys[i]; };
  Components components(n);
  for (std::size_t a = 0; a < n; ++a) {
    const auto& ga = tiles[a].geoTransform;
    const double dx = ga[1], dy = -ga[5];
    const double westA = ga[0], eastA = ga[0] + dx * static_cast<double>(tiles[a].width);
    const double northA = ga[3], southA = ga[3] - dy * static_cast<double>(tiles[a].height);
    for (std::size_t b = a + 1; b < n; ++b) {
      const auto& gb = tiles[b].geoTransform;
      if (key(a) != key(b) || tiles[a].crsWkt != tiles[b].crsWkt || !sameSpacing(dx, gb[1]) ||
          !sameSpacing(dy, -gb[5]) || !aligned(ga[0], gb[0], dx) || !aligned(ga[3], gb[3], dy)) {
        continue;
      }
      const double westB = gb[0], eastB = gb[0] + dx * static_cast<double>(tiles[b].width);
      const double northB = gb[3], southB = gb[3] - dy * static_cast<double>(tiles[b].height);
      // Touching cell to cell, sharing an edge row or overlapping; half a sample of slack.
      if (westB <= eastA + 0.5 * dx && westA <= eastB + 0.5 * dx && southB <= northA + 0.5 * dy &&
          southA <= northB + 0.5 * dy) {
        components.join(a, b);
      }
    }
  }
  std::vector<std::vector<std::size_t>> surfaces;
  std::vector<std::size_t> surfaceOfRoot(n, n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t root = components.find(i);
    if (surfaceOfRoot[root] == n) {
      surfaceOfRoot[root] = surfaces.size();
      surfaces.emplace_back();
    }
    surfaces[surfaceOfRoot[root]].push_back(i);
  }
  return surfaces;
}

}  // namespace pbdam::formats
