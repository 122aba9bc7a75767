// DEMs that come as tiles (SRTM, Copernicus GLO-30, national lidar, HRSC/CTX): a directory or a
// glob pattern read as sets of tiles, the tiles probed without reading their heights, and the
// tiles that make one surface — the same CRS and spacing on one grid, touching or overlapping —
// joined into one grid through a GDAL VRT, so that heights across a seam are sampled as from one
// grid. A VRT file is already one DEM to readDem. Thread-safety: free functions, safe from any
// thread.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "pbdam/formats/DemReader.h"
#include "pbdam/formats/HeightGrid.h"
#include "pbdam/formats/Result.h"

namespace pbdam::formats {

/// True when `path` names a set of DEM files rather than one: an existing directory, or a path
/// that does not exist and holds a glob character (* ? [).
bool namesDemSet(const std::filesystem::path& path);

/// The files of a set of raster tiles (DEMs or imagery), sorted: a directory's regular files
/// (hidden files and the side files GDAL and the survey agencies put beside rasters — .aux.xml,
/// .prj, world files, .xml, .txt, ... — left out; subdirectories not entered), or a glob
/// pattern's matches. A path that is one file gives itself. Errors: an unreadable directory, a
/// set with no files (naming it).
Result<std::vector<std::filesystem::path>> expandDemSet(const std::filesystem::path& path);

/// A tile as GDAL describes it, without its heights.
struct DemTileProbe final {
  std::filesystem::path path;  ///< the tile's file
  std::int64_t width = 0;      ///< columns
  std::int64_t height = 0;     ///< rows
  /// GDAL's geotransform in the tile's own CRS: x0, dx, rx, y0, ry, dy.
  std::array<double, 6> geoTransform{};
  std::string crsWkt;  ///< the CRS as WKT, empty when the file has none
  std::string body;    ///< "mars", "earth", "moon" or "" (GridSource::body)
  std::string format;  ///< GDAL driver short name
};

/// Opens `path` with GDAL and reads its size, georeference and CRS. Errors name the file: not
/// a raster GDAL reads (a corrupt tile), no georeference, a rotated grid.
Result<DemTileProbe> probeDemTile(const std::filesystem::path& path);

/// Probes every tile. Errors: the first tile that fails probeDemTile; a tile on another body
/// than the first tile that names one (naming both).
Result<std::vector<DemTileProbe>> probeDemTiles(const std::vector<std::filesystem::path>& paths);

/// Partitions tiles into surfaces: tiles join when their keys (`keys[i]`, e.g. a height
/// offset's index; empty means all 0) and CRSs are equal, their spacings agree to 1e-9, their
/// grids are aligned to a hundredth of a sample, and their extents touch or overlap (within
/// half a sample) — transitively. Each surface lists tile indices in ascending order; surfaces
/// are ordered by their first tile.
std::vector<std::vector<std::size_t>> groupDemTiles(const std::vector<DemTileProbe>& tiles,
                                                    const std::vector<int>& keys = {});

/// Reads tiles that groupDemTiles put in one surface as one grid (a GDAL VRT mosaic of them,
/// read like readDem reads a file; where tiles overlap, their samples agree or the first valid
/// one wins). `name` is what the grid's GridSource::path says (the set as the user named it).
/// Errors name the tile or the set.
Result<HeightGrid> readDemMosaic(const std::vector<std::filesystem::path>& tiles,
                                 const std::string& name, const DemReadOptions& options = {});

}  // namespace pbdam::formats
