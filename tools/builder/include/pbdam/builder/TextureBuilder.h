// Texture tile generation for the per-face texture quadtree (docs/architecture.md "Geometry";
// [P-BDAM 2003] §3/§4: one texture node per pair of level-2t geometry nodes; docs/builder.md
// "Textures"): shaded relief with a hypsometric tint from the DEM by default, or an equirectangular
// image (optionally shaded), each tile with a 2-texel border sampled across face edges, and the
// tile's texture error (largest texel ground size). Thread-safety: buildTextureTile and
// textureTileErrorMeters are pure; concurrent calls (on any tiles) are safe provided the
// source's height function is safe to call concurrently (HeightGrid sampling is).
#pragma once

#include <cstdint>
#include <functional>
#include <glm/vec2.hpp>
#include <optional>
#include <vector>

#include "pbdam/builder/HypsometricTint.h"
#include "pbdam/formats/HeightGrid.h"
#include "pbdam/formats/Image.h"
#include "pbdam/formats/Result.h"
#include "pbdam/formats/TextureTile.h"
#include "pbdam/runtime/Planet.h"

namespace pbdam::builder {

/// One node of a face's texture quadtree and the tile to make for it.
///
/// The tile has sizeTexels² texels; the inner (sizeTexels − 2·borderTexels)² texels cover the
/// face square [qi, qi+1]·2^-level × [qj, qj+1]·2^-level in (u, v) exactly: inner texel k
/// (k = 0 .. inner−1) has its centre at u = (qi + (k + 0.5)/inner)·2^-level (likewise v with qj).
/// Border texels continue that spacing beyond the square; where that leaves the face they show
/// the neighbouring faces (the tangent-adjusted face plane extends past its edges, CubeMap.h).
/// Texel (x, y) of the result follows TextureTileImage's orientation: u grows with x, v with y,
/// row 0 at the lowest v.
struct TextureTileRequest final {
  int face = 0;                    ///< CubeFace index, 0..5
  int level = 0;                   ///< quadtree level t: 0 is the whole face, at most 24
  std::uint32_t qi = 0;            ///< column of the node, 0 .. 2^level − 1 (along u)
  std::uint32_t qj = 0;            ///< row of the node, 0 .. 2^level − 1 (along v)
  std::uint32_t sizeTexels = 256;  ///< total side including both borders
  std::uint32_t borderTexels = 2;  ///< filtering border on each side
};

/// Hillshading parameters (standard cartographic defaults: light from the north-west, 45° up).
struct ReliefShading final {
  double lightAzimuthDegrees = 315.0;   ///< clockwise from north: 315 = from the north-west
  double lightElevationDegrees = 45.0;  ///< above the horizon
  /// Heights are multiplied by this before slopes are taken (1 = true relief). Planet-scale
  /// DEMs sampled at kilometres per texel look flat at 1: slopes over 10–20 km are a few
  /// percent. 8 was chosen by eye on MOLA (Mars, 0.25°) and ETOPO5 (Earth, 1/12°) previews:
  /// craters, volcanoes and ridges read clearly, nothing saturates to black.
  double verticalExaggeration = 8.0;
  /// How much the shading changes the tint: 0 = flat tint, 1 = full hillshade. Flat ground
  /// keeps the tint; slopes facing the light lighten it towards white, those facing away darken.
  double strength = 0.7;
};

/// What a texture shows. Holds no data of its own except the Planet value; the pointed-to
/// image and the objects captured by heightMeters must outlive every call that uses them.
struct TextureSource final {
  /// Height in metres above the planet's reference surface at a geodetic latitude and a
  /// longitude (degrees, any range), nullopt where there is no data. Required for shaded relief
  /// and for shaded imagery; may be empty for plain imagery. Must be safe to call from several
  /// threads at once when tiles are built in parallel.
  std::function<std::optional<double>(double latDegrees, double lonDegrees)> heightMeters;
  /// When set, texels show this image (sampled bilinearly, k×k supersampled with
  /// k = clamp(ceil(texel ground size / image pixel ground size), 1, 8)) instead of the tint.
  const formats::GeoImage* imagery = nullptr;
  /// Shading applied on top of imagery, 0..1 (0: the image as is). Needs heightMeters.
  double imageryShadingStrength = 0.0;
  /// Local images drawn over the result, in order (coarsest inset first): where layer i's
  /// weight w (times the image's alpha / 255) is above 0, the texel becomes w·(the layer's
  /// colour) + (1 − w)·(what lies below), supersampled as `imagery` is and shaded with
  /// imageryShadingStrength. Weights must be safe to call from several threads.
  struct ImageryLayer final {
    const formats::GeoImage* image = nullptr;
    std::function<double(double latDegrees, double lonDegrees)> weight;
  };
  std::vector<ImageryLayer> layers;
  runtime::Planet planet = runtime::Planet::mars();
  HypsometricRamp ramp;
  ReliefShading shading;
};

/// A generated tile: Rgba8 texels (alpha 255) and the tile's texture error.
struct TextureTileResult final {
  formats::TextureTileImage image;
  /// The largest distance in metres between the surface points of two adjacent inner texel
  /// centres (textureTileErrorMeters). A parent's texels are twice its children's, so the
  /// errors nest: parent ≥ child.
  double textureErrorMeters = 0.0;
};

/// Checks a request: face 0..5, level 0..24, qi and qj < 2^level, sizeTexels ≤
/// kMaxTextureTileTexels with at least 1 inner texel, and a border that stays within half a face
/// of the node ((borderTexels + 1)·2^-level / inner < 0.5). InvalidArgument naming the field
/// otherwise.
formats::Result<void> validateTextureTileRequest(const TextureTileRequest& request);

/// Returns the face (u, v) of the centre of texel (x, y) of the requested tile; x and y may lie
/// anywhere (border texels, or beyond, give (u, v) outside the node's square).
glm::dvec2 textureTexelFaceUv(const TextureTileRequest& request, double x, double y) noexcept;

/// Returns the texture error of the requested tile (see TextureTileResult) without sampling any
/// data: the maximum over its inner texels of the surface distance (chord) between adjacent
/// texel centres on `planet`'s reference surface. The request must be valid.
double textureTileErrorMeters(const runtime::Planet& planet,
                              const TextureTileRequest& request) noexcept;

/// Makes the tile. For each texel: the direction of its centre (through the extended face plane
/// for border texels), its ground spacing (the larger of the distances to its neighbours along u
/// and along v), then
///  - shaded relief: the tint of the height at the centre blended with four samples half a
///    spacing east/west/north/south of it (weights 1/2 and 1/8 each, a small footprint filter),
///    shaded by the slopes between those four samples, so coarse levels show coarse relief;
///    water (hasOcean ramps, height < 0) is shaded at half strength; texels without any height
///    get kNoDataTint;
///  - imagery: the mean of the k×k image samples over the texel's footprint, shaded with
///    imageryShadingStrength when heights are given; texels outside the image fall back to the
///    shaded relief (or kNoDataTint without heights).
/// Deterministic: the same source and request give the same bytes on any thread; a tile is made
/// on the calling thread only. InvalidArgument for an invalid request or a source with neither
/// heights nor imagery.
formats::Result<TextureTileResult> buildTextureTile(const TextureSource& source,
                                                    const TextureTileRequest& request);

/// Makes the normal-map tile that goes with the colour tile of `colour` (whose size and border
/// must be even): Rg8, half the colour tile's size and border, so that its inner texels cover
/// the same square and the same texture coordinates address both. Each texel holds the true
/// relief's unit normal (heights sampled at the texel centres, slopes by central differences
/// as for the shaded relief, no exaggeration; flat where there is no height) in the frame of
/// runtime/NormalMap.h. Deterministic; InvalidArgument for an invalid request or odd sizes.
formats::Result<formats::TextureTileImage> buildNormalTile(const TextureSource& source,
                                                           const TextureTileRequest& colour);

/// Convenience height function for TextureSource: samples `grid` (bicubic, or bilinear when
/// `bicubic` is false). The grid must outlive the returned function.
std::function<std::optional<double>(double, double)> heightFunctionFromGrid(
    const formats::HeightGrid& grid, bool bicubic = true);

}  // namespace pbdam::builder
