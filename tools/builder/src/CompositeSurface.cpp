// The composite of a base DEM and insets (CompositeSurface.h).
#include "pbdam/builder/CompositeSurface.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>
#include <numeric>

#include "pbdam/formats/DemTileSet.h"
#include "pbdam/formats/ScratchArray.h"

using namespace pbdam::formats;

namespace pbdam::builder {
namespace {

double spacingOf(const HeightGrid& grid) noexcept {
  return std::max(grid.geometry().latSpacingDegrees, grid.geometry().lonSpacingDegrees);
}

/// Whether the position (r, c) just beyond `grid`'s edge, next to its sample (qr, qc), lies on
/// another surface that continues the grid side by side rather than lying under it: one of
/// `others` has data at (r, c) but not a few of its own spacings inside the grid from there.
/// Such an edge is a seam between surfaces, not where the data ends.
bool continuedBeside(const HeightGrid& grid, const std::vector<const HeightGrid*>& others,
                     std::int64_t r, std::int64_t c, std::int64_t qr, std::int64_t qc) {
  const double lat = grid.latOfRowDegrees(r), lon = grid.lonOfColumnDegrees(c);
  for (const HeightGrid* other : others) {
    if (!other->sampleBilinear(lat, lon)) continue;
    // Inward, past the half cell of `other` that its sampling reaches beyond its last sample.
    const auto steps =
        static_cast<std::int64_t>(std::ceil(spacingOf(*other) / spacingOf(grid))) + 1;
    const std::int64_t ir = qr + (qr - r) * steps, ic = qc + (qc - c) * steps;
    if (!other->sampleBilinear(grid.latOfRowDegrees(ir), grid.lonOfColumnDegrees(ic))) {
      return true;
    }
  }
  return false;
}

/// Where an inset's edge distances go: beside a file-backed grid a mapped scratch file in
/// `scratchDirectory` (memory when none is given or none can be made), else memory.
ScratchArray<std::uint16_t> allocateDistances(const HeightGrid& grid,
                                              const std::filesystem::path& scratchDirectory) {
  const auto n = static_cast<std::size_t>(grid.width() * grid.height());
  return ScratchArray<std::uint16_t>::allocate(
      n, grid.fileBacked() ? scratchDirectory : std::filesystem::path());
}

/// Per sample, the Chebyshev distance (in samples) to the nearest sample that is nodata or
/// beyond the grid's edge, capped at `cap`, into `out`: two passes of the 3 × 3 distance
/// transform, row by row (a mapped grid and a mapped `out` are read and written in order, their
/// pages let go every few megabytes). Beyond the edge where another surface continues the grid
/// side by side (continuedBeside) counts as inside: no band along a seam between surfaces of
/// different spacings.
void edgeDistances(const HeightGrid& grid, std::uint16_t cap,
                   const std::vector<const HeightGrid*>& others,
                   const ScratchArray<std::uint16_t>& out) {
  const std::int64_t w = grid.width(), h = grid.height();
  std::uint16_t* const d = out.elements().data();
  const auto at = [&](std::int64_t r, std::int64_t c) -> std::uint16_t& {
    return d[static_cast<std::size_t>(r * w + c)];
  };
  // Beyond the edge counts as outside (distance 0) unless another surface continues it there.
  const auto get = [&](std::int64_t r, std::int64_t c) -> std::uint16_t {
    if (r >= 0 && r < h && c >= 0 && c < w) return at(r, c);
    if (others.empty()) return 0;
    const std::int64_t qr = std::clamp<std::int64_t>(r, 0, h - 1);
    const std::int64_t qc = std::clamp<std::int64_t>(c, 0, w - 1);
    return continuedBeside(grid, others, r, c, qr, qc) ? cap : std::uint16_t{0};
  };
  // Rows between letting the mapped pages go: about 16 MB of heights.
  const std::int64_t releaseEvery = std::max<std::int64_t>(1, (std::int64_t{4} << 20) / w);
  const auto release = [&](std::int64_t r) {
    if (r % releaseEvery != 0) return;
    grid.releaseResident();
    if (out.file()) (void)out.file()->releaseResident();
  };
  for (std::int64_t r = 0; r < h; ++r) {
    for (std::int64_t c = 0; c < w; ++c) at(r, c) = std::isnan(grid.at(r, c)) ? 0 : cap;
    release(r);
  }
  const auto relax = [&](std::int64_t r, std::int64_t c, std::int64_t dr) {
    std::uint16_t& v = at(r, c);
    if (v == 0) return;
    const std::uint16_t m =
        std::min({get(r - dr, c - 1), get(r - dr, c), get(r - dr, c + 1), get(r, c - dr)});
    v = std::min<std::uint16_t>(v, static_cast<std::uint16_t>(std::min<int>(m + 1, cap)));
  };
  for (std::int64_t r = 0; r < h; ++r) {
    for (std::int64_t c = 0; c < w; ++c) relax(r, c, 1);
    release(r);
  }
  for (std::int64_t r = h; r-- > 0;) {
    for (std::int64_t c = w; c-- > 0;) relax(r, c, -1);
    release(r);
  }
  grid.releaseResident();
  if (out.file()) {
    (void)out.file()->releaseResident();
    (void)out.file()->protectReadOnly();
  }
}

double smoothstep(double x) noexcept {
  const double t = std::clamp(x, 0.0, 1.0);
  return t * t * (3.0 - 2.0 * t);
}

}  // namespace

std::int64_t transitionBandSamples(const HeightGrid& below, const HeightGrid& inset) noexcept {
  const double ratio = spacingOf(below) / spacingOf(inset);
  const std::int64_t quarter = std::min(inset.width(), inset.height()) / 4;
  return std::max<std::int64_t>(
      16, std::min(quarter, static_cast<std::int64_t>(std::ceil(ratio - 1e-9))));
}

Result<void> checkInset(const InsetSpec& spec, const HeightGrid& inset, const HeightGrid& base,
                        const std::string& planetSpec) {
  const std::string name = spec.path.string();
  const std::string& body = inset.source().body;
  if (!body.empty() && planetSpec.rfind(body, 0) != 0 && planetSpec.rfind("sphere", 0) != 0 &&
      planetSpec.rfind("ellipsoid", 0) != 0) {
    return invalidArgument(name + ": the inset's CRS is on " + body + " but --planet is " +
                           planetSpec);
  }
  const std::string& datum = inset.source().verticalDatum;
  const std::string& baseDatum = base.source().verticalDatum;
  if (!datum.empty() && !baseDatum.empty() && datum != baseDatum && !spec.offsetMeters) {
    return invalidArgument(name + ": the inset's heights are on the vertical datum '" + datum +
                           "', the base's on '" + baseDatum +
                           "'; give --inset-offset (metres added to the inset's heights)");
  }
  if (spec.offsetMeters && !std::isfinite(*spec.offsetMeters)) {
    return invalidArgument(name + ": --inset-offset must be a finite number of metres");
  }
  if (spacingOf(inset) >= spacingOf(base)) {
    return invalidArgument(name + ": its samples (" + std::to_string(spacingOf(inset)) +
                           "°) are not finer than the base's (" + std::to_string(spacingOf(base)) +
                           "°); an inset adds detail the base lacks");
  }
  if (inset.computeStats().validCount == 0) return invalidArgument(name + ": has no valid samples");
  return {};
}

Result<CompositeSurface> CompositeSurface::make(HeightGrid base, std::vector<InsetSpec> specs,
                                                std::vector<HeightGrid> grids,
                                                const VoidFillOptions& fill) {
  std::vector<InsetSurfaceInput> surfaces;
  for (std::size_t k = 0; k < grids.size(); ++k) {
    const LatLonBounds bounds = grids[k].bounds();
    surfaces.push_back(InsetSurfaceInput{std::move(grids[k]), {k}, 1, {bounds}});
  }
  return make(std::move(base), std::move(specs), std::move(surfaces), fill);
}

Result<CompositeSurface> CompositeSurface::make(HeightGrid base, std::vector<InsetSpec> specs,
                                                std::vector<InsetSurfaceInput> surfaces,
                                                const VoidFillOptions& fill) {
  if (surfaces.size() > kMaxInsetSurfaces) {
    return invalidArgument(std::to_string(surfaces.size()) +
                           " separate inset surfaces: a leaf's sources name at "
                           "most " +
                           std::to_string(kMaxInsetSurfaces) +
                           " (tiles that touch or overlap at one spacing count as one surface)");
  }
  // The manifest's order: by first spec.
  std::vector<std::size_t> byFirstSpec(surfaces.size());
  std::iota(byFirstSpec.begin(), byFirstSpec.end(), std::size_t{0});
  std::stable_sort(byFirstSpec.begin(), byFirstSpec.end(), [&](std::size_t a, std::size_t b) {
    return surfaces[a].specs.front() < surfaces[b].specs.front();
  });
  std::vector<std::size_t> manifestIndexOf(surfaces.size());
  for (std::size_t m = 0; m < byFirstSpec.size(); ++m) manifestIndexOf[byFirstSpec[m]] = m;
  // Coarsest first, so that each finer inset is blended over what lies below it.
  std::vector<std::size_t> order(byFirstSpec);
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return spacingOf(surfaces[a].grid) > spacingOf(surfaces[b].grid);
  });
  CompositeSurface s;
  s.base_ = std::move(base);
  s.specs_ = std::move(specs);
  for (const std::size_t k : order) {
    InsetSurfaceInput& input = surfaces[k];
    Inset inset;
    inset.offsetMeters = s.specs_[input.specs.front()].offsetMeters.value_or(0.0);
    // Voids filled over what is below (the base and the coarser insets joined so far); their
    // heights are the inset's own, so the offset comes off what lies below.
    const double offset = inset.offsetMeters;
    auto filled = fillVoids(input.grid, fill, [&s, offset](double lat, double lon) {
      std::optional<double> h = s.heightBelow(s.insets_.size(), lat, lon);
      if (h) *h -= offset;
      return h;
    });
    if (!filled) return std::move(filled).error();
    inset.voids = filled->report;
    inset.voidRuns = std::move(filled->runs);
    // What it blends into: the finest coarser inset whose box holds its box, else the base.
    const HeightGrid* below = &s.base_;
    const LatLonBounds box = filled->grid.bounds();
    for (const Inset& coarser : s.insets_) {
      const LatLonBounds c = coarser.grid.bounds();
      if (c.southDegrees <= box.southDegrees && c.northDegrees >= box.northDegrees &&
          c.westDegrees <= box.westDegrees && c.eastDegrees >= box.eastDegrees) {
        below = &coarser.grid;  // coarsest first: the last that holds it is the finest
      }
    }
    inset.bandSamples = transitionBandSamples(*below, filled->grid);
    // Surfaces of other spacings beside it: no band along the seams with them.
    std::vector<const HeightGrid*> others;
    for (const InsetSurfaceInput& other : surfaces) {
      if (&other != &input && spacingOf(other.grid) != spacingOf(input.grid)) {
        others.push_back(&other.grid);
      }
    }
    const ScratchArray<std::uint16_t> distances =
        allocateDistances(filled->grid, fill.scratchDirectory);
    edgeDistances(filled->grid,
                  static_cast<std::uint16_t>(std::min<std::int64_t>(inset.bandSamples + 1, 65535)),
                  others, distances);
    inset.edgeDistance = distances.elements();
    inset.edgeDistanceOwner = distances.share();
    inset.edgeDistanceFile = distances.file();
    inset.grid = std::move(filled).value().grid;
    inset.specs = std::move(input.specs);
    inset.specBounds = std::move(input.specBounds);
    inset.tiles = input.tiles;
    inset.manifestIndex = manifestIndexOf[k];
    s.insets_.push_back(std::move(inset));
  }
  return s;
}

VoidMap CompositeSurface::voidMap() const {
  VoidMap map;
  bool any = false;
  for (std::size_t m = 0; m < insets_.size(); ++m) {
    const Inset& inset = insets_[insetOfManifestIndex(m)];
    const GridGeometry& g = inset.grid.geometry();
    map.surfaces.push_back(VoidGrid{g.firstLatDegrees, g.firstLonDegrees, g.latSpacingDegrees,
                                    g.lonSpacingDegrees, static_cast<std::uint32_t>(g.width),
                                    static_cast<std::uint32_t>(g.height), inset.voidRuns});
    any = any || !inset.voidRuns.empty();
  }
  if (!any) map.surfaces.clear();
  return map;
}

double CompositeSurface::specWeight(std::size_t k, double lat, double lon) const noexcept {
  for (std::size_t i = 0; i < insets_.size(); ++i) {
    const Inset& inset = insets_[i];
    for (std::size_t j = 0; j < inset.specs.size(); ++j) {
      if (inset.specs[j] != k) continue;
      if (inset.specs.size() > 1) {
        const LatLonBounds& b = inset.specBounds[j];
        double l = std::fmod(lon - b.westDegrees, 360.0);
        if (l < 0.0) l += 360.0;
        if (lat < b.southDegrees || lat > b.northDegrees || l > b.eastDegrees - b.westDegrees) {
          return 0.0;
        }
      }
      return weightOf(i, lat, lon);
    }
  }
  return 0.0;
}

LatLonBounds CompositeSurface::specFootprint(std::size_t k) const noexcept {
  for (const Inset& inset : insets_) {
    for (std::size_t j = 0; j < inset.specs.size(); ++j) {
      if (inset.specs[j] == k) return inset.specBounds[j];
    }
  }
  return LatLonBounds{};
}

std::size_t CompositeSurface::insetOfManifestIndex(std::size_t manifestIndex) const noexcept {
  for (std::size_t i = 0; i < insets_.size(); ++i) {
    if (insets_[i].manifestIndex == manifestIndex) return i;
  }
  return insets_.size();
}

Result<CompositeSurface> CompositeSurface::read(HeightGrid base, std::vector<InsetSpec> specs,
                                                const DemReadOptions& readOptions,
                                                const std::string& planetSpec,
                                                const VoidFillOptions& fill) {
  // Every tile of every spec, probed; the key keeps specs of different offsets apart.
  std::vector<std::filesystem::path> paths;
  std::vector<std::size_t> specOf;
  std::vector<int> keys;
  for (std::size_t k = 0; k < specs.size(); ++k) {
    auto files = expandDemSet(specs[k].path);
    if (!files) return std::move(files).error();
    int key = static_cast<int>(k);
    for (std::size_t j = 0; j < k; ++j) {
      if (specs[j].offsetMeters == specs[k].offsetMeters) {
        key = static_cast<int>(j);
        break;
      }
    }
    for (auto& file : *files) {
      paths.push_back(std::move(file));
      specOf.push_back(k);
      keys.push_back(key);
    }
  }
  auto tiles = probeDemTiles(paths);
  if (!tiles) return std::move(tiles).error();
  std::vector<InsetSurfaceInput> surfaces;
  for (const std::vector<std::size_t>& members : groupDemTiles(*tiles, keys)) {
    std::vector<std::filesystem::path> files;
    InsetSurfaceInput input;
    for (const std::size_t t : members) {
      files.push_back(paths[t]);
      if (std::find(input.specs.begin(), input.specs.end(), specOf[t]) == input.specs.end()) {
        input.specs.push_back(specOf[t]);
      }
    }
    std::sort(input.specs.begin(), input.specs.end());
    // Named as the user named it: the spec, or the specs it joins.
    std::string name;
    for (const std::size_t k : input.specs) {
      if (!name.empty()) name += " + ";
      name += specs[k].path.string();
    }
    auto grid = readDemMosaic(files, name, readOptions);
    if (!grid) return std::move(grid).error();
    // Checked as the spec, named by its first tile when the spec is a set (a directory or
    // glob): what cannot be joined is said of a file the user can find.
    InsetSpec first = specs[input.specs.front()];
    if (namesDemSet(first.path)) first.path = files.front();
    if (auto ok = checkInset(first, *grid, base, planetSpec); !ok) return std::move(ok).error();
    const LatLonBounds b = grid->bounds();
    if (!(b.southDegrees >= -90.0 && b.northDegrees <= 90.0)) {
      return invalidArgument(name + ": its samples reach latitudes beyond ±90°");
    }
    // Each spec's own footprint, for its imagery: the box of its tiles where the surface is
    // geographic and holds several specs, else the surface's.
    for (const std::size_t k : input.specs) {
      LatLonBounds own = b;
      if (input.specs.size() > 1 && !grid->source().warped) {
        bool any = false;
        for (const std::size_t t : members) {
          if (specOf[t] != k) continue;
          const auto& g = (*tiles)[t].geoTransform;
          const LatLonBounds tb{g[3] + g[5] * static_cast<double>((*tiles)[t].height), g[0], g[3],
                                g[0] + g[1] * static_cast<double>((*tiles)[t].width)};
          own = any ? LatLonBounds{std::min(own.southDegrees, tb.southDegrees),
                                   std::min(own.westDegrees, tb.westDegrees),
                                   std::max(own.northDegrees, tb.northDegrees),
                                   std::max(own.eastDegrees, tb.eastDegrees)}
                    : tb;
          any = true;
        }
      }
      input.specBounds.push_back(own);
    }
    input.tiles = members.size();
    input.grid = std::move(grid).value();
    surfaces.push_back(std::move(input));
  }
  return make(std::move(base), std::move(specs), std::move(surfaces), fill);
}

double CompositeSurface::weightOf(std::size_t i, double lat, double lon) const noexcept {
  const Inset& inset = insets_[i];
  const GridGeometry& g = inset.grid.geometry();
  double dl = std::fmod(lon - g.firstLonDegrees, 360.0);
  if (dl < 0.0) dl += 360.0;
  // Outside its cells (the hull of its sample centres, and for pixel-is-area samples the half
  // cell beyond it) the inset has no weight. In that half cell it holds its outermost samples'
  // weights, which are 0 where its data ends and above 0 only along a seam with a surface
  // beside it (edgeDistances): two surfaces abutting cell to cell meet at their cells' shared
  // edge, with no strip of the base between their sample centres.
  const double margin = g.pixelIsArea ? 0.5 : 0.0;
  const auto lastRow = static_cast<double>(g.height - 1);
  const auto lastCol = static_cast<double>(g.width - 1);
  double col = dl / g.lonSpacingDegrees;
  if (col > lastCol + margin) col = (dl - 360.0) / g.lonSpacingDegrees;  // just west of it
  double row = (g.firstLatDegrees - lat) / g.latSpacingDegrees;
  if (!(row >= -margin && col >= -margin && row <= lastRow + margin && col <= lastCol + margin)) {
    return 0.0;
  }
  row = std::clamp(row, 0.0, lastRow);
  col = std::clamp(col, 0.0, lastCol);
  const auto r0 = std::min(static_cast<std::int64_t>(row), g.height - 1);
  const auto c0 = std::min(static_cast<std::int64_t>(col), g.width - 1);
  const std::int64_t r1 = std::min(r0 + 1, g.height - 1), c1 = std::min(c0 + 1, g.width - 1);
  const double fr = row - static_cast<double>(r0), fc = col - static_cast<double>(c0);
  const auto band = static_cast<double>(inset.bandSamples);
  const auto sampleWeight = [&](std::int64_t r, std::int64_t c) {
    const double d = inset.edgeDistance[static_cast<std::size_t>(r * g.width + c)];
    return std::clamp((d - 1.0) / band, 0.0, 1.0);
  };
  const double top = (1.0 - fc) * sampleWeight(r0, c0) + fc * sampleWeight(r0, c1);
  const double bottom = (1.0 - fc) * sampleWeight(r1, c0) + fc * sampleWeight(r1, c1);
  return smoothstep((1.0 - fr) * top + fr * bottom);
}

std::optional<double> CompositeSurface::heightBelow(std::size_t upTo, double lat,
                                                    double lon) const noexcept {
  // Bicubic, bilinear where bicubic lacks data: what a base-only build resamples.
  std::optional<double> h = base_.sampleBicubic(lat, lon);
  if (!h) h = base_.sampleBilinear(lat, lon);
  for (std::size_t i = 0; i < upTo; ++i) {
    const double w = weightOf(i, lat, lon);
    if (w <= 0.0) continue;
    // A weight above 0 means the four samples around the point are valid (their band weights
    // are 0 next to nodata), so the inset has a height here.
    std::optional<double> own = insets_[i].grid.sampleBicubic(lat, lon);
    if (!own) own = insets_[i].grid.sampleBilinear(lat, lon);
    if (!own) continue;
    const double mine = *own + insets_[i].offsetMeters;
    h = (w >= 1.0 || !h) ? mine : w * mine + (1.0 - w) * *h;
  }
  return h;
}

std::optional<double> CompositeSurface::heightAt(double lat, double lon) const noexcept {
  return heightBelow(insets_.size(), lat, lon);
}

SourceAt CompositeSurface::sourceAt(double lat, double lon) const noexcept {
  for (std::size_t i = insets_.size(); i-- > 0;) {
    const double w = weightOf(i, lat, lon);
    if (w > 0.0) return SourceAt{static_cast<int>(i), w};
  }
  return SourceAt{};
}

void CompositeSurface::forEachSample(
    const std::function<void(int, double, double, double)>& fn) const {
  const auto finestFrom = [&](std::size_t from, double lat, double lon) {
    for (std::size_t j = insets_.size(); j-- > from;) {
      if (weightOf(j, lat, lon) > 0.0) return true;
    }
    return false;
  };
  for (std::int64_t r = 0; r < base_.height(); ++r) {
    const double lat = base_.latOfRowDegrees(r);
    for (std::int64_t c = 0; c < base_.width(); ++c) {
      const float v = base_.at(r, c);
      if (std::isnan(v)) continue;
      const double lon = base_.lonOfColumnDegrees(c);
      if (!finestFrom(0, lat, lon)) fn(-1, lat, lon, static_cast<double>(v));
    }
  }
  for (std::size_t i = 0; i < insets_.size(); ++i) {
    const HeightGrid& g = insets_[i].grid;
    for (std::int64_t r = 0; r < g.height(); ++r) {
      const double lat = g.latOfRowDegrees(r);
      for (std::int64_t c = 0; c < g.width(); ++c) {
        if (std::isnan(g.at(r, c))) continue;
        const double lon = g.lonOfColumnDegrees(c);
        const double w = weightOf(i, lat, lon);
        if (w <= 0.0 || finestFrom(i + 1, lat, lon)) continue;
        const double mine = static_cast<double>(g.at(r, c)) + insets_[i].offsetMeters;
        const std::optional<double> below = heightBelow(i, lat, lon);
        fn(static_cast<int>(i), lat, lon,
           (w >= 1.0 || !below) ? mine : w * mine + (1.0 - w) * *below);
      }
    }
  }
}

}  // namespace pbdam::builder
