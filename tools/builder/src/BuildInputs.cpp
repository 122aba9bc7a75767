// Options checked, inputs read, lattice sized, fingerprint made (BuildInputs.h;
// docs/builder.md "Checkpoints" for the fingerprint).
#include "BuildInputs.h"

#include "ForestPlan.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <span>

#include "pbdam/formats/Checksum.h"
#include "pbdam/formats/DatasetFormat.h"
#include "pbdam/formats/Manifest.h"
#include "pbdam/formats/PatchCodec.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::builder {
namespace {

namespace fs = std::filesystem;

std::string hex32(std::uint32_t v) {
  char s[16];
  std::snprintf(s, sizeof s, "%08x", v);
  return s;
}

std::string exact(double v) {
  char s[40];
  std::snprintf(s, sizeof s, "%.17g", v);
  return s;
}

}  // namespace

DemReadOptions demReadOptions(const BuildOptions& o) {
  DemReadOptions r;
  r.raw = o.rawLayout;
  r.mapAtBytes = o.demMapAtBytes;
  std::error_code ec;
  fs::path dir = fs::absolute(o.outDir, ec);
  if (ec) return r;
  // is_directory reports a missing path through `ec` too: that only means "go up".
  while (!fs::is_directory(dir, ec) && dir.has_relative_path()) dir = dir.parent_path();
  if (fs::is_directory(dir, ec)) r.scratchDirectory = dir;
  return r;
}

Result<BuildInputs> prepareInputs(const BuildOptions& o) {
  BuildInputs in;
  in.leafCells = o.leafVertices - 1;
  if (o.leafVertices < 3 || !std::has_single_bit(in.leafCells) || in.leafCells > 256) {
    return invalidArgument("--leaf-vertices " + std::to_string(o.leafVertices) +
                           ": must be 2^k + 1 between 3 and 257 (e.g. 17 or 33)");
  }
  if (o.minPatchTriangles < 16 || o.minPatchTriangles > kPatchMaxVertices) {
    return invalidArgument("--min-patch-triangles " + std::to_string(o.minPatchTriangles) +
                           ": must be between 16 and 65535");
  }
  if (!(o.errorMargin >= 0.25 && o.errorMargin <= 4.0)) {
    return invalidArgument(
        "--error-margin " + exact(o.errorMargin) +
        ": must be between 0.25 and 4 (a level's error is at least 1 + r times its "
        "children's)");
  }
  if (o.textureTileTexels < 16 || o.textureTileTexels > 4096 || o.textureTileTexels % 8 != 0) {
    return invalidArgument("--texture-tile " + std::to_string(o.textureTileTexels) +
                           ": must be a multiple of 8 between 16 and 4096 (its normal map is "
                           "half as large, in 4 × 4 blocks)");
  }
  if (o.depth && (*o.depth % 2 != 0 || *o.depth > 28)) {
    return invalidArgument("--levels " + std::to_string(*o.depth) +
                           ": must be an even depth up to 28");
  }
  if (!(o.heightStepMeters > 0.0) || o.threads < 0)
    return invalidArgument("bad height step or threads");
  auto planet = Planet::fromSpec(o.planetSpec);
  if (!planet) return std::move(planet).error();
  in.planet = *planet;
  std::error_code ec;
  if (fs::exists(o.outDir, ec) && !fs::is_directory(o.outDir, ec)) {
    return invalidArgument(o.outDir.string() + ": exists and is not a directory");
  }
  if (fs::exists(o.outDir / kManifestFileName, ec) && !o.force) {
    return invalidArgument(o.outDir.string() +
                           ": already holds a dataset (use --force to replace it)");
  }

  auto dem = readDem(o.demPath, demReadOptions(o));
  if (!dem) return std::move(dem).error();
  const std::string& body = dem->source().body;
  const std::string spec = planet->name();
  if (!body.empty() && spec.rfind(body, 0) != 0 && spec.rfind("sphere", 0) != 0 &&
      spec.rfind("ellipsoid", 0) != 0) {
    return invalidArgument(o.demPath.string() + ": the DEM's CRS is on " + body +
                           " but --planet is " + spec);
  }
  if (!o.texturePath.empty()) {
    auto image = readImage(o.texturePath);
    if (!image) return std::move(image).error();
    in.imagery = std::move(image).value();
  }

  // Lattice size: at least the DEM's density across 90° of longitude.
  in.n = in.leafCells;
  if (o.depth) {
    in.depth = *o.depth;
    if (in.depth > formats::kMaxBintreeDepth) {
      return invalidArgument("the bintree would be " + std::to_string(in.depth) +
                             " levels deep; a dataset holds at most " +
                             std::to_string(formats::kMaxBintreeDepth) +
                             " (larger leaves: --leaf-vertices 33 takes two levels off)");
    }
    in.n = in.leafCells << (in.depth / 2);
  } else {
    in.depth = levelOfDensity(*dem, in.leafCells);
  }
  in.baseDepth = in.depth;
  in.deepRegions = o.deepRegions;
  if (!o.insets.empty()) {
    // The insets' surfaces (tiles that touch at one spacing joined, voids filled), each a deep
    // region at its density's level, in the manifest's order.
    DemReadOptions insetOptions = demReadOptions(o);
    insetOptions.raw.reset();  // the raw-grid options describe --dem only
    auto composite =
        CompositeSurface::read(*dem, o.insets, insetOptions, planet->name(),
                               VoidFillOptions{.scratchDirectory = insetOptions.scratchDirectory});
    if (!composite) return std::move(composite).error();
    in.composite = std::move(composite).value();
    for (std::size_t m = 0; m < in.composite->insets().size(); ++m) {
      const HeightGrid& grid = in.composite->insets()[in.composite->insetOfManifestIndex(m)].grid;
      // At least one level (two bintree levels) below the base, so the inset adds leaves.
      const auto level = std::max(levelOfDensity(grid, in.leafCells), in.baseDepth + 2);
      in.deepRegions.push_back(DeepRegion{grid.bounds(), static_cast<int>(level)});
    }
  }
  for (const DeepRegion& r : in.deepRegions) {
    if (r.leafLevel % 2 != 0 || r.leafLevel <= static_cast<int>(in.baseDepth) ||
        !(r.bounds.southDegrees < r.bounds.northDegrees) ||
        !(r.bounds.westDegrees < r.bounds.eastDegrees)) {
      return invalidArgument("a deep region needs an even leaf level above the depth " +
                             std::to_string(in.baseDepth) + " and a non-empty box");
    }
    in.depth = std::max(in.depth, static_cast<std::uint32_t>(r.leafLevel));
  }
  // A uniform lattice is stored densely (6·(N+1)² heights: 6.4 GB at 16384); an adaptive one
  // in tiles at the spacing of the leaves over them (LatticeTiles), so its size follows the
  // leaves. Past 2^15 cells a patch's legs span more than its barycentrics' 2^15 steps: its
  // vertices then lie on the sub-lattice those steps address (docs/decisions.md "Finer than
  // 2^15 cells a face").
  const std::uint64_t maxCells = in.deepRegions.empty() ? 16384 : std::uint64_t{1} << 24;
  if (std::uint64_t{in.leafCells} << (in.depth / 2) > maxCells) {
    return invalidArgument(
        "the lattice would have " + std::to_string(std::uint64_t{in.leafCells} << (in.depth / 2)) +
        " cells per face side; at most " + std::to_string(maxCells) +
        (in.deepRegions.empty() ? " (choose --levels or larger leaves)"
                                : " with insets or deep regions (coarser insets, a "
                                  "shallower --deep-region level or larger leaves)"));
  }
  in.n = in.leafCells << (in.depth / 2);
  in.dem = std::move(dem).value();
  in.demSource = in.dem->source();
  if (in.composite) {
    auto imagery = readInsetImagery(*in.composite);
    if (!imagery) return std::move(imagery).error();
    in.insetImagery = std::move(imagery).value();
  }
  return in;
}

Result<std::vector<std::optional<GeoImage>>> readInsetImagery(const CompositeSurface& composite) {
  std::vector<std::optional<GeoImage>> out;
  for (std::size_t i = 0; i < composite.specs().size(); ++i) {
    const InsetSpec& spec = composite.specs()[i];
    if (spec.texturePath.empty()) {
      out.emplace_back();
      continue;
    }
    auto image = readImage(spec.texturePath);
    if (!image) return std::move(image).error();
    const LatLonBounds footprint = composite.specFootprint(i);
    if (!image->georeferenced()) {
      // An image without a georeference is taken to cover its inset's footprint exactly.
      const std::int64_t w = image->width();
      const std::int64_t h = image->height();
      std::vector<std::uint8_t> rgba = image->rgba();
      out.emplace_back(GeoImage(w, h, std::move(rgba), footprint, true));
      continue;
    }
    const LatLonBounds& b = image->bounds();
    if (!(b.southDegrees < footprint.northDegrees && b.northDegrees > footprint.southDegrees &&
          b.westDegrees < footprint.eastDegrees && b.eastDegrees > footprint.westDegrees)) {
      char box[160];
      std::snprintf(box, sizeof box, "%.4f..%.4f°N %.4f..%.4f°E", b.southDegrees, b.northDegrees,
                    b.westDegrees, b.eastDegrees);
      return invalidArgument(spec.texturePath.string() + ": its georeference (" + box +
                             ") does not overlap its inset " + spec.path.filename().string());
    }
    out.emplace_back(std::move(image).value());
  }
  return out;
}

std::uint32_t levelOfDensity(const HeightGrid& grid, std::uint32_t leafCells) {
  const double across = 90.0 / grid.geometry().lonSpacingDegrees;
  const std::uint32_t n =
      std::max(leafCells, std::bit_ceil(static_cast<std::uint32_t>(std::ceil(across - 1e-9))));
  return 2 * static_cast<std::uint32_t>(std::countr_zero(n / leafCells));
}

std::string demCrc32(const HeightGrid& dem) {
  // In 64 MB pieces, dropping a mapped DEM's pages after each: one pass over a 2 GB DEM would
  // otherwise bring all of it into the process's RSS.
  const auto bytes = std::as_bytes(dem.heightsMeters());
  constexpr std::size_t kPiece = std::size_t{64} << 20;
  std::uint32_t crc = 0;
  for (std::size_t at = 0; at < bytes.size(); at += kPiece) {
    crc = crc32(bytes.subspan(at, std::min(kPiece, bytes.size() - at)), crc);
    dem.releaseResident();
  }
  return hex32(crc);
}

std::vector<std::pair<std::string, std::string>> fingerprintOf(const BuildOptions& o,
                                                               const BuildInputs& in) {
  const GridGeometry& g = in.dem->geometry();
  std::vector<std::pair<std::string, std::string>> f;
  // What the levels are made from and what the carry holds: a checkpoint of another version of
  // the builder's levels cannot be continued (docs/builder.md "Checkpoints").
  f.emplace_back("builder-levels", std::to_string(kBuilderLevelsVersion));
  // And the dataset format the tiles and patches are made for (version 5 added the normal-map
  // tiles to the texture checkpoint's entries).
  f.emplace_back("dataset-format", std::to_string(formats::kDatasetFormatVersion));
  f.emplace_back("dem", o.demPath.filename().string());
  f.emplace_back("dem-grid", std::to_string(g.width) + "x" + std::to_string(g.height) + "@" +
                                 exact(g.firstLatDegrees) + "," + exact(g.firstLonDegrees) + "/" +
                                 exact(g.latSpacingDegrees) + "," + exact(g.lonSpacingDegrees) +
                                 (g.pixelIsArea ? "/area" : "/point"));
  f.emplace_back("dem-crc32", demCrc32(*in.dem));
  std::string texture = "shaded-relief";
  if (in.imagery) {
    texture = o.texturePath.filename().string() +
              "/crc32:" + hex32(crc32(std::as_bytes(std::span(in.imagery->rgba()))));
  }
  f.emplace_back("texture", texture);
  f.emplace_back("planet", in.planet->name());
  f.emplace_back("levels", std::to_string(in.depth));
  if (in.composite) {
    const CompositeSurface& composite = *in.composite;
    for (std::size_t m = 0; m < composite.insets().size(); ++m) {
      const CompositeSurface::Inset& surface =
          composite.insets()[composite.insetOfManifestIndex(m)];
      std::string names;
      for (const std::size_t k : surface.specs) {
        if (!names.empty()) names += '+';
        names += composite.specs()[k].path.filename().string();
      }
      f.emplace_back("inset", names + "/tiles:" + std::to_string(surface.tiles) +
                                  "/crc32:" + demCrc32(surface.grid) +
                                  "/offset:" + exact(surface.offsetMeters));
    }
    for (std::size_t k = 0; k < composite.specs().size(); ++k) {
      if (const auto& image = in.insetImagery[k]) {
        f.emplace_back("inset-texture",
                       composite.specs()[k].texturePath.filename().string() +
                           "/crc32:" + hex32(crc32(std::as_bytes(std::span(image->rgba())))));
      }
    }
  }
  for (const DeepRegion& r : in.deepRegions) {
    f.emplace_back("deep-region", exact(r.bounds.southDegrees) + "," + exact(r.bounds.westDegrees) +
                                      "," + exact(r.bounds.northDegrees) + "," +
                                      exact(r.bounds.eastDegrees) + "@" +
                                      std::to_string(r.leafLevel));
  }
  f.emplace_back("lattice", std::to_string(in.n));
  f.emplace_back("leaf-vertices", std::to_string(o.leafVertices));
  f.emplace_back("min-patch-triangles", std::to_string(o.minPatchTriangles));
  f.emplace_back("error-margin", exact(o.errorMargin));
  f.emplace_back("texture-tile", std::to_string(o.textureTileTexels));
  f.emplace_back("texture-format", o.textureFormat == TexelFormat::Bc1 ? "bc1" : "rgba8");
  f.emplace_back("texture-quality", o.bc1Quality == Bc1Quality::High ? "high" : "fast");
  f.emplace_back("height-step", exact(o.heightStepMeters));
  return f;
}

std::vector<InsetSurfaceSummary> insetSummaries(const BuildOptions& o, const BuildInputs& in) {
  std::vector<InsetSurfaceSummary> out;
  if (!in.composite) return out;
  const std::vector<ManifestInset> records = manifestInsets(o, in);
  for (std::size_t m = 0; m < records.size(); ++m) {
    const auto& surface = in.composite->insets()[in.composite->insetOfManifestIndex(m)];
    out.push_back(InsetSurfaceSummary{records[m].file, surface.tiles, surface.voids});
  }
  return out;
}

/// The manifest's record of each inset surface, ordered by the first spec it holds.
std::vector<ManifestInset> manifestInsets(const BuildOptions& o, const BuildInputs& in) {
  std::vector<ManifestInset> out;
  if (!in.composite) return out;
  const CompositeSurface& composite = *in.composite;
  for (std::size_t m = 0; m < composite.insets().size(); ++m) {
    const CompositeSurface::Inset& surface = composite.insets()[composite.insetOfManifestIndex(m)];
    const HeightGrid& g = surface.grid;
    const DeepRegion& region = in.deepRegions[o.deepRegions.size() + m];
    ManifestInset record;
    std::string texture;
    for (const std::size_t k : surface.specs) {
      const InsetSpec& spec = composite.specs()[k];
      if (!record.file.empty()) record.file += " + ";
      record.file += spec.path.filename().string();
      if (!spec.texturePath.empty()) {
        if (!texture.empty()) texture += " + ";
        texture += spec.texturePath.filename().string();
      }
    }
    record.format = g.source().format;
    record.samples = static_cast<std::uint64_t>(g.computeStats().validCount);
    record.southDegrees = region.bounds.southDegrees;
    record.westDegrees = region.bounds.westDegrees;
    record.northDegrees = region.bounds.northDegrees;
    record.eastDegrees = region.bounds.eastDegrees;
    record.leafLevel = static_cast<std::uint32_t>(region.leafLevel);
    record.bandSamples = static_cast<std::uint32_t>(surface.bandSamples);
    record.offsetMeters = surface.offsetMeters;
    if (!texture.empty()) record.texture = texture;
    out.push_back(std::move(record));
  }
  return out;
}

/// With insets: a leaf's sources, from which source defines the composite at each point of its
/// regular patch (an inset's bit where it has a weight, the base's where it has less than 1).
std::function<std::uint32_t(const BinTriangle&)> leafSources(const BuildOptions& o,
                                                             const BuildInputs& in,
                                                             const ForestPlan& plan,
                                                             const Lattice& lattice) {
  if (!in.composite) return {};
  // The composite orders its insets coarsest first; the manifest by their first spec, and bit
  // 1 + m is the manifest's inset m (CompositeSurface::make caps them at 31).
  (void)o;
  std::vector<std::uint32_t> bitOf(in.composite->insets().size(), 0);
  for (std::size_t i = 0; i < bitOf.size(); ++i) {
    bitOf[i] = std::uint32_t{2} << in.composite->insets()[i].manifestIndex;
  }
  return [&in, &plan, &lattice, bitOf](const BinTriangle& t) {
    std::uint32_t sources = 0;
    for (const LatticeXY p : plan.leafPatch(t).points) {
      const runtime::GeodeticPosition g =
          in.planet->directionToGeodetic(lattice.direction(t.face, p));
      const SourceAt s = in.composite->sourceAt(g.latDegrees, g.lonDegrees);
      if (s.inset >= 0) sources |= bitOf[static_cast<std::size_t>(s.inset)];
      if (s.inset < 0 || s.weight < 1.0) sources |= 1U;
    }
    return sources;
  };
}

}  // namespace pbdam::builder
