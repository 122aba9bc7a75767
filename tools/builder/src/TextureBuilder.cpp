// Texture tile generation (TextureBuilder.h, HypsometricTint.h): shaded relief with hypsometric
// tint, or supersampled imagery, for one node of a face's texture quadtree (docs/architecture.md
// "Geometry"; [P-BDAM 2003] §3/§4, the texture quadtree; docs/builder.md "Textures").
#include "pbdam/builder/TextureBuilder.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <glm/geometric.hpp>
#include <numbers>
#include <span>
#include <string>
#include <vector>

#include "pbdam/runtime/CubeMap.h"
#include "pbdam/runtime/NormalMap.h"

using namespace pbdam::formats;
using namespace pbdam::runtime;

namespace pbdam::builder {
namespace {

constexpr double kDegrees = std::numbers::pi / 180.0;
constexpr int kMaxLevel = 24;
constexpr int kMaxImageSupersampling = 8;

// ---- colour ramps -------------------------------------------------------------------------

struct RampStop final {
  double at;  // metres (ocean ramp) or fraction of the range (dry ramp)
  Rgb8 colour;
};

// Bathymetry: light blue at the shore, dark blue in the trenches.
constexpr std::array<RampStop, 6> kWaterStops{{
    {-11000.0, {10, 22, 68}},
    {-6000.0, {22, 56, 128}},
    {-3500.0, {42, 96, 170}},
    {-1500.0, {72, 138, 204}},
    {-200.0, {118, 178, 226}},
    {0.0, {162, 210, 240}},
}};

// Land: lowland green, yellow-tan hills, brown mountains, grey-brown high plateaus, snow only on
// the highest peaks (so that Tibet reads as a plateau, not a glacier).
constexpr std::array<RampStop, 9> kLandStops{{
    {0.0, {78, 138, 76}},
    {250.0, {122, 166, 92}},
    {700.0, {190, 192, 124}},
    {1300.0, {204, 168, 110}},
    {2100.0, {168, 122, 82}},
    {3100.0, {142, 112, 98}},
    {4500.0, {178, 162, 150}},
    {5800.0, {232, 230, 226}},
    {7000.0, {255, 255, 255}},
}};

// Dry bodies, over the dataset's range: the classic MOLA-style blue → cyan → green → yellow →
// orange → red-brown → white, with the stops packed into the lower half where most of a
// planet's surface lies (Mars: 90% of the area within −5..+5 km of a −8..+21 km range).
constexpr std::array<RampStop, 9> kDryStops{{
    {0.00, {28, 30, 104}},
    {0.10, {38, 86, 178}},
    {0.20, {58, 156, 196}},
    {0.28, {92, 176, 116}},
    {0.36, {208, 204, 104}},
    {0.46, {214, 144, 70}},
    {0.60, {170, 88, 62}},
    {0.80, {196, 160, 150}},
    {1.00, {255, 255, 255}},
}};

// std::lround(std::clamp(value, 0, 255)) without the library call (two per channel of every
// texel): on [0, 255] truncation is exact and so is the fraction it leaves, so rounding half
// away from zero is one comparison. NaN goes through lround, whatever it makes of it.
std::uint8_t toChannel(double value) noexcept {
  const double clamped = std::clamp(value, 0.0, 255.0);
  if (std::isnan(clamped)) return static_cast<std::uint8_t>(std::lround(clamped));
  const int whole = static_cast<int>(clamped);
  return static_cast<std::uint8_t>(whole + (clamped - whole >= 0.5 ? 1 : 0));
}

Rgb8 interpolate(std::span<const RampStop> stops, double at) noexcept {
  if (at <= stops.front().at) return stops.front().colour;
  if (at >= stops.back().at) return stops.back().colour;
  std::size_t upper = 1;
  while (upper + 1 < stops.size() && stops[upper].at < at) ++upper;
  const RampStop& a = stops[upper - 1];
  const RampStop& b = stops[upper];
  const double t = (at - a.at) / (b.at - a.at);
  Rgb8 colour{};
  for (std::size_t c = 0; c < 3; ++c) {
    const double value = a.colour[c] + t * (b.colour[c] - a.colour[c]);
    colour[c] = toChannel(value);
  }
  return colour;
}

// ---- geometry -----------------------------------------------------------------------------

// East and north unit vectors (ECEF) at a geodetic latitude/longitude.
struct LocalAxes final {
  glm::dvec3 east;
  glm::dvec3 north;
};

LocalAxes localAxes(double latDegrees, double lonDegrees) noexcept {
  const double sinLat = std::sin(latDegrees * kDegrees);
  const double cosLat = std::cos(latDegrees * kDegrees);
  const double sinLon = std::sin(lonDegrees * kDegrees);
  const double cosLon = std::cos(lonDegrees * kDegrees);
  return {glm::dvec3(-sinLon, cosLon, 0.0), glm::dvec3(-sinLat * cosLon, -sinLat * sinLon, cosLat)};
}

// Texel centres of a tile, one row at a time: a texel's relief and spacing read only its own
// row and the rows above and below, so three rows are held instead of the whole tile (a tile's
// worth of centres is megabytes, freshly mapped and faulted in for every tile otherwise).
// Columns are [first, first + count); row y lives in slot (y − first) mod 3.
struct TexelRow final {
  std::vector<glm::dvec3> surface;
  std::vector<GeodeticPosition> positions;     // empty unless positions were asked for
  std::vector<std::optional<double>> heights;  // empty without a height function
};

using HeightFunction = std::function<std::optional<double>(double, double)>;

class TexelRows final {
 public:
  // `heightMeters` (may be null: no heights) must outlive the object; positions are computed
  // when asked for or when heights are (heights are looked up at them).
  TexelRows(const Planet& planet, const TextureTileRequest& request, int first, int count,
            bool withPositions, const HeightFunction* heightMeters)
      : planet_(planet),
        face_(cubeFaceFromIndex(request.face)),
        first_(first),
        heightMeters_(heightMeters),
        withPositions_(withPositions || heightMeters != nullptr) {
    // A texel's u depends on its column only and v on its row: each plane coordinate is
    // computed once per column or row (CubeMap::faceUvToDirection's two tangents, not two per
    // texel).
    const auto n = static_cast<std::size_t>(count);
    planeU_.resize(n);
    planeV_.resize(n);
    for (int k = 0; k < count; ++k) {
      const glm::dvec2 uv = textureTexelFaceUv(request, first + k, first + k);
      planeU_[static_cast<std::size_t>(k)] = CubeMap::uvToPlaneCoordinate(uv.x);
      planeV_[static_cast<std::size_t>(k)] = CubeMap::uvToPlaneCoordinate(uv.y);
    }
    for (TexelRow& row : rows_) {
      row.surface.resize(n);
      if (withPositions_) row.positions.resize(n);
      if (heightMeters_ != nullptr) row.heights.resize(n);
    }
  }

  // Index of column x in a row's vectors.
  std::size_t column(int x) const noexcept { return static_cast<std::size_t>(x - first_); }

  // Row y, which must be one of the last three loaded.
  const TexelRow& row(int y) const noexcept { return rows_[slot(y)]; }

  // Computes row y (first <= y < first + count) into its slot, replacing row y − 3.
  void load(int y) {
    TexelRow& row = rows_[slot(y)];
    const double planeV = planeV_[static_cast<std::size_t>(y - first_)];
    for (std::size_t k = 0; k < planeU_.size(); ++k) {
      const glm::dvec3 direction = CubeMap::planeToDirection(face_, planeU_[k], planeV);
      row.surface[k] = planet_.directionToSurfaceEcef(direction);
      if (withPositions_) row.positions[k] = planet_.directionToGeodetic(direction);
    }
    // The heights in a pass of their own: the lookups are independent of each other, so their
    // DEM reads overlap instead of each waiting behind a texel's trigonometry.
    if (heightMeters_ == nullptr) return;
    for (std::size_t k = 0; k < planeU_.size(); ++k) {
      row.heights[k] = (*heightMeters_)(row.positions[k].latDegrees, row.positions[k].lonDegrees);
    }
  }

 private:
  std::size_t slot(int y) const noexcept { return static_cast<std::size_t>(y - first_) % 3; }

  const Planet& planet_;
  CubeFace face_;
  int first_;
  const HeightFunction* heightMeters_;
  bool withPositions_;
  std::vector<double> planeU_;
  std::vector<double> planeV_;
  std::array<TexelRow, 3> rows_;
};

// Largest distance from each texel of row y, columns [lo, hi), to its right neighbour (within
// the columns) and, when `next` is given, to the texel above it in row `next`.
double largestSpacingInRow(const TexelRows& rows, const TexelRow& here, const TexelRow* next,
                           int lo, int hi) noexcept {
  double largest = 0.0;
  for (int x = lo; x < hi; ++x) {
    const glm::dvec3& p = here.surface[rows.column(x)];
    if (x + 1 < hi) largest = std::max(largest, glm::distance(p, here.surface[rows.column(x + 1)]));
    if (next != nullptr) {
      largest = std::max(largest, glm::distance(p, next->surface[rows.column(x)]));
    }
  }
  return largest;
}

// ---- shading ------------------------------------------------------------------------------

// Everything the relief computation learns about one texel.
struct ReliefSample final {
  bool valid = false;
  double tintHeightMeters = 0.0;  // centre weighted 1/2, the four neighbours 1/8 each
  double relief = 1.0;            // lit fraction relative to flat ground: 0 .. 1/sin(elevation)
  glm::dvec2 gradient{0.0};       // true slope: metres of height per metre east, north
};

// A texel's relief reads its four grid neighbours (Horn-style central differences over the
// 3×3 neighbourhood's cross) from TexelRows, where each centre's height was looked up once: the
// DEM is sampled once per texel, not five times.
class ReliefSampler final {
 public:
  ReliefSampler(const TextureSource& source, const TexelRows& rows)
      : rows_(rows),
        exaggeration_(source.shading.verticalExaggeration),
        sinElevation_(std::sin(source.shading.lightElevationDegrees * kDegrees)) {
    const double azimuth = source.shading.lightAzimuthDegrees * kDegrees;
    const double cosElevation = std::cos(source.shading.lightElevationDegrees * kDegrees);
    light_ = glm::dvec3(cosElevation * std::sin(azimuth), cosElevation * std::cos(azimuth),
                        sinElevation_);
  }

  // Relief of texel (x, y) (not on the rows' outer ring) from its neighbours; rows y − 1, y and
  // y + 1 must be loaded.
  ReliefSample sample(int x, int y) const {
    ReliefSample result;
    const TexelRow& here = rows_.row(y);
    const TexelRow& above = rows_.row(y + 1);
    const TexelRow& below = rows_.row(y - 1);
    const std::size_t at = rows_.column(x);
    const std::optional<double>& centre = here.heights[at];
    // The four neighbours in the order east (x + 1), west, north (y + 1), south.
    const std::array<Neighbour, 4> around = {Neighbour{&here, rows_.column(x + 1)},
                                             Neighbour{&here, rows_.column(x - 1)},
                                             Neighbour{&above, at}, Neighbour{&below, at}};
    double weightSum = 0.0;
    double weighted = 0.0;
    if (centre) {
      weighted += 0.5 * *centre;
      weightSum += 0.5;
    }
    for (const Neighbour& k : around) {
      if (const std::optional<double>& h = k.height()) {
        weighted += 0.125 * *h;
        weightSum += 0.125;
      }
    }
    if (weightSum == 0.0) return result;
    result.valid = true;
    result.tintHeightMeters = weighted / weightSum;

    // The height difference along each grid axis (central where both neighbours have data,
    // else one-sided to the centre) and the ground step it spans, in the texel's east/north
    // plane; the slope is the gradient that explains both.
    const GeodeticPosition& position = here.positions[at];
    const LocalAxes axes = localAxes(position.latDegrees, position.lonDegrees);
    struct Difference {
      bool valid = false;
      glm::dvec2 step{0.0};  // east, north metres
      double dh = 0.0;
    };
    const auto difference = [&](const Neighbour& plus, const Neighbour& minus) {
      Difference d;
      const std::optional<double>& hp = plus.height();
      const std::optional<double>& hm = minus.height();
      glm::dvec3 from;
      glm::dvec3 to;
      if (hp && hm) {
        to = plus.surface();
        from = minus.surface();
        d.dh = *hp - *hm;
      } else if (hp && centre) {
        to = plus.surface();
        from = here.surface[at];
        d.dh = *hp - *centre;
      } else if (hm && centre) {
        to = here.surface[at];
        from = minus.surface();
        d.dh = *centre - *hm;
      } else {
        return d;
      }
      const glm::dvec3 step = to - from;
      d.step = glm::dvec2(glm::dot(step, axes.east), glm::dot(step, axes.north));
      d.valid = glm::dot(d.step, d.step) > 0.0;
      return d;
    };
    const Difference du = difference(around[0], around[1]);
    const Difference dv = difference(around[2], around[3]);
    glm::dvec2 gradient(0.0);  // metres of height per metre east, north
    const double det = du.step.x * dv.step.y - du.step.y * dv.step.x;
    if (du.valid && dv.valid && det != 0.0) {
      gradient =
          glm::dvec2(du.dh * dv.step.y - dv.dh * du.step.y, du.step.x * dv.dh - dv.step.x * du.dh) /
          det;
    } else if (du.valid) {
      gradient = du.step * (du.dh / glm::dot(du.step, du.step));
    } else if (dv.valid) {
      gradient = dv.step * (dv.dh / glm::dot(dv.step, dv.step));
    }
    result.gradient = gradient;
    const glm::dvec2 slope = exaggeration_ * gradient;
    const glm::dvec3 normal = glm::normalize(glm::dvec3(-slope.x, -slope.y, 1.0));
    result.relief = std::max(0.0, glm::dot(normal, light_)) / sinElevation_;
    return result;
  }

 private:
  // A texel of one of the loaded rows.
  struct Neighbour final {
    const TexelRow* row;
    std::size_t column;
    const std::optional<double>& height() const noexcept { return row->heights[column]; }
    const glm::dvec3& surface() const noexcept { return row->surface[column]; }
  };

  const TexelRows& rows_;
  double exaggeration_;
  double sinElevation_;
  glm::dvec3 light_;
};

// Applies hillshading to a colour: relief 1 (flat) keeps it, darker relief scales it down,
// brighter relief blends it towards white. `strength` in [0, 1].
std::array<double, 3> shade(const std::array<double, 3>& colour, double relief,
                            double strength) noexcept {
  const double factor = 1.0 + strength * (relief - 1.0);
  std::array<double, 3> out{};
  for (std::size_t c = 0; c < 3; ++c) {
    out[c] = factor <= 1.0 ? colour[c] * factor : colour[c] + (255.0 - colour[c]) * (factor - 1.0);
  }
  return out;
}

std::array<double, 3> toDouble(const Rgb8& colour) noexcept {
  return {static_cast<double>(colour[0]), static_cast<double>(colour[1]),
          static_cast<double>(colour[2])};
}

void store(std::uint8_t* texel, const std::array<double, 3>& colour) noexcept {
  for (std::size_t c = 0; c < 3; ++c) {
    texel[c] = toChannel(colour[c]);
  }
  texel[3] = 255;
}

// Ground size in metres of one image pixel along latitude, and along longitude at the equator.
struct ImagePixelSize final {
  double latMeters = 0.0;
  double lonMetersAtEquator = 0.0;
};

ImagePixelSize imagePixelSize(const GeoImage& image, const Planet& planet) noexcept {
  const LatLonBounds& bounds = image.bounds();
  const double radius = planet.equatorialRadiusMeters();
  return {(bounds.northDegrees - bounds.southDegrees) / static_cast<double>(image.height()) *
              kDegrees * radius,
          (bounds.eastDegrees - bounds.westDegrees) / static_cast<double>(image.width()) *
              kDegrees * radius};
}

/// An image's colour over one texel: the mean of k×k bilinear subsamples spread over the
/// texel's footprint in (u, v), k = clamp(⌈texel spacing / pixel size⌉, 1, 8); nullopt when no
/// subsample falls inside the image.
struct SeenColour final {
  std::array<double, 3> colour{};
  double alpha = 0.0;  ///< mean alpha, 0..255
};

std::optional<SeenColour> supersample(const GeoImage& image, const ImagePixelSize& pixel,
                                      const Planet& planet, CubeFace face, glm::dvec2 centreUv,
                                      double texelUv, double spacing, double latDegrees) noexcept {
  const double pixelMeters = std::min(
      pixel.latMeters, pixel.lonMetersAtEquator * std::max(std::cos(latDegrees * kDegrees), 1e-6));
  const int k =
      std::clamp(static_cast<int>(std::ceil(spacing / pixelMeters)), 1, kMaxImageSupersampling);
  SeenColour seen;
  int count = 0;
  for (int b = 0; b < k; ++b) {
    for (int a = 0; a < k; ++a) {
      const glm::dvec2 offset((a + 0.5) / k - 0.5, (b + 0.5) / k - 0.5);
      const glm::dvec3 direction = CubeMap::faceUvToDirection(face, centreUv + texelUv * offset);
      const GeodeticPosition p = planet.directionToGeodetic(direction);
      if (const auto rgba = image.sampleBilinear(p.latDegrees, p.lonDegrees)) {
        for (std::size_t c = 0; c < 3; ++c) seen.colour[c] += static_cast<double>((*rgba)[c]);
        seen.alpha += static_cast<double>((*rgba)[3]);
        ++count;
      }
    }
  }
  if (count == 0) return std::nullopt;
  for (double& c : seen.colour) c /= count;
  seen.alpha /= count;
  return seen;
}

// The colour of each texel of a tile from its loaded rows (TextureBuilder.h, buildTextureTile).
class TexelColouring final {
 public:
  TexelColouring(const TextureSource& source, const TextureTileRequest& request,
                 const TexelRows& rows)
      : source_(source),
        request_(request),
        rows_(rows),
        relief_(source, rows),
        face_(cubeFaceFromIndex(request.face)),
        texelUv_(
            std::ldexp(1.0 / static_cast<double>(request.sizeTexels - 2 * request.borderTexels),
                       -request.level)),
        haveHeights_(static_cast<bool>(source.heightMeters)),
        imageryStrength_(std::clamp(source.imageryShadingStrength, 0.0, 1.0)),
        wantRelief_(haveHeights_ && (source.imagery == nullptr || imageryStrength_ > 0.0)),
        reliefStrength_(std::clamp(source.shading.strength, 0.0, 1.0)),
        pixel_(source.imagery != nullptr ? imagePixelSize(*source.imagery, source.planet)
                                         : ImagePixelSize{}) {
    for (const TextureSource::ImageryLayer& layer : source.layers) {
      layerPixels_.push_back(imagePixelSize(*layer.image, source.planet));
    }
  }

  // Writes texel (x, y) (RGBA) to `texel`; rows y − 1 .. y + 1 must be loaded.
  void colour(int x, int y, std::uint8_t* texel) const {
    const TexelRow& here = rows_.row(y);
    const std::size_t at = rows_.column(x);
    const GeodeticPosition& position = here.positions[at];
    const bool anyImagery = source_.imagery != nullptr || !source_.layers.empty();
    // The texel's footprint: only the image samples need it.
    double spacing = 0.0;
    glm::dvec2 centreUv(0.0);
    if (anyImagery) {
      const double spacingU =
          0.5 * glm::distance(here.surface[rows_.column(x + 1)], here.surface[rows_.column(x - 1)]);
      const double spacingV =
          0.5 * glm::distance(rows_.row(y + 1).surface[at], rows_.row(y - 1).surface[at]);
      spacing = std::max(spacingU, spacingV);
      centreUv = textureTexelFaceUv(request_, x, y);
    }

    // Relief is needed for the tint and for shaded imagery.
    ReliefSample reliefSample;
    if (wantRelief_) reliefSample = relief_.sample(x, y);

    std::optional<std::array<double, 3>> colour;
    double strength = reliefStrength_;
    if (source_.imagery != nullptr) {
      if (const auto seen = supersample(*source_.imagery, pixel_, source_.planet, face_, centreUv,
                                        texelUv_, spacing, position.latDegrees)) {
        colour = seen->colour;
        strength = imageryStrength_;
        if (source_.ramp.hasOcean && reliefSample.valid && reliefSample.tintHeightMeters < 0.0) {
          strength *= 0.5;
        }
      } else if (haveHeights_ && !wantRelief_) {
        // Outside the image: fall back to the shaded relief.
        reliefSample = relief_.sample(x, y);
      }
    }
    if (!colour && reliefSample.valid) {
      colour = toDouble(hypsometricTint(reliefSample.tintHeightMeters, source_.ramp));
      // Water is shaded more softly than land: bathymetry reads as depth, not as mountains.
      if (source_.ramp.hasOcean && reliefSample.tintHeightMeters < 0.0) strength *= 0.5;
    }
    for (std::size_t i = 0; i < source_.layers.size(); ++i) {
      const TextureSource::ImageryLayer& layer = source_.layers[i];
      const double w = layer.weight(position.latDegrees, position.lonDegrees);
      if (!(w > 0.0)) continue;
      const auto seen = supersample(*layer.image, layerPixels_[i], source_.planet, face_, centreUv,
                                    texelUv_, spacing, position.latDegrees);
      if (!seen) continue;
      const double a = std::clamp(w * seen->alpha / 255.0, 0.0, 1.0);
      if (!colour) {
        if (a < 1.0) continue;  // nothing below to blend with
        colour = seen->colour;
      } else {
        for (std::size_t c = 0; c < 3; ++c) (*colour)[c] += a * (seen->colour[c] - (*colour)[c]);
      }
      strength += a * (imageryStrength_ - strength);
    }
    if (!colour) {
      store(texel, toDouble(kNoDataTint));
      return;
    }
    if (reliefSample.valid && strength > 0.0) {
      colour = shade(*colour, reliefSample.relief, strength);
    }
    store(texel, *colour);
  }

 private:
  const TextureSource& source_;
  const TextureTileRequest& request_;
  const TexelRows& rows_;
  ReliefSampler relief_;
  CubeFace face_;
  double texelUv_;
  bool haveHeights_;
  double imageryStrength_;
  bool wantRelief_;
  double reliefStrength_;
  ImagePixelSize pixel_;
  std::vector<ImagePixelSize> layerPixels_;
};

}  // namespace

// ---- public functions ---------------------------------------------------------------------

Rgb8 hypsometricTint(double heightMeters, const HypsometricRamp& ramp) noexcept {
  if (std::isnan(heightMeters)) return kNoDataTint;
  if (ramp.hasOcean) {
    return heightMeters < 0.0 ? interpolate(kWaterStops, heightMeters)
                              : interpolate(kLandStops, heightMeters);
  }
  const double span = ramp.maxMeters - ramp.minMeters;
  const double at = span > 0.0 ? (heightMeters - ramp.minMeters) / span : 0.5;
  return interpolate(kDryStops, at);
}

Result<void> validateTextureTileRequest(const TextureTileRequest& request) {
  const auto invalid = [](const std::string& what) {
    return makeError(ErrorCode::InvalidArgument, "texture tile request: " + what);
  };
  if (request.face < 0 || request.face >= kCubeFaceCount) {
    return invalid("face " + std::to_string(request.face) + " is not in 0..5");
  }
  if (request.level < 0 || request.level > kMaxLevel) {
    return invalid("level " + std::to_string(request.level) + " is not in 0.." +
                   std::to_string(kMaxLevel));
  }
  const std::uint64_t nodes = std::uint64_t{1} << request.level;
  if (request.qi >= nodes || request.qj >= nodes) {
    return invalid("node (" + std::to_string(request.qi) + ", " + std::to_string(request.qj) +
                   ") is outside level " + std::to_string(request.level) + " (0.." +
                   std::to_string(nodes - 1) + ")");
  }
  if (request.sizeTexels > kMaxTextureTileTexels ||
      2ull * request.borderTexels >= request.sizeTexels) {
    return invalid("size " + std::to_string(request.sizeTexels) + " with border " +
                   std::to_string(request.borderTexels) + " (size at most " +
                   std::to_string(kMaxTextureTileTexels) + ", more than twice the border)");
  }
  // The border (and the one extra ring used for texel spacing) must stay within the half face
  // beyond the node's square that the cube map's face planes extend to (CubeMap.h).
  const double inner = static_cast<double>(request.sizeTexels - 2 * request.borderTexels);
  if (std::ldexp((request.borderTexels + 1.0) / inner, -request.level) >= 0.5) {
    return invalid("border " + std::to_string(request.borderTexels) + " of " +
                   std::to_string(request.sizeTexels) +
                   " texels reaches beyond the neighbouring faces");
  }
  return {};
}

glm::dvec2 textureTexelFaceUv(const TextureTileRequest& request, double x, double y) noexcept {
  const double inner = static_cast<double>(request.sizeTexels - 2 * request.borderTexels);
  const double border = static_cast<double>(request.borderTexels);
  const double u = (static_cast<double>(request.qi) + (x - border + 0.5) / inner);
  const double v = (static_cast<double>(request.qj) + (y - border + 0.5) / inner);
  return {std::ldexp(u, -request.level), std::ldexp(v, -request.level)};
}

double textureTileErrorMeters(const Planet& planet, const TextureTileRequest& request) noexcept {
  const int border = static_cast<int>(request.borderTexels);
  const int inner = static_cast<int>(request.sizeTexels) - 2 * border;
  TexelRows rows(planet, request, border, inner, false, nullptr);
  double largest = 0.0;
  rows.load(border);
  for (int y = border; y < border + inner; ++y) {
    const bool last = y + 1 == border + inner;
    if (!last) rows.load(y + 1);
    largest =
        std::max(largest, largestSpacingInRow(rows, rows.row(y), last ? nullptr : &rows.row(y + 1),
                                              border, border + inner));
  }
  return largest;
}

Result<TextureTileResult> buildTextureTile(const TextureSource& source,
                                           const TextureTileRequest& request) {
  if (Result<void> valid = validateTextureTileRequest(request); !valid) {
    return std::move(valid).error();
  }
  const bool haveHeights = static_cast<bool>(source.heightMeters);
  if (!haveHeights && source.imagery == nullptr) {
    return makeError(ErrorCode::InvalidArgument,
                     "texture source has neither a height function nor imagery");
  }
  if (source.imagery != nullptr &&
      (source.imagery->width() <= 0 || source.imagery->height() <= 0)) {
    return makeError(ErrorCode::InvalidArgument, "texture source imagery is empty");
  }

  const int size = static_cast<int>(request.sizeTexels);
  const int border = static_cast<int>(request.borderTexels);
  // Texel centres one beyond the tile on every side, for the spacing and relief at the
  // outermost texels.
  TexelRows rows(source.planet, request, -1, size + 2, true,
                 haveHeights ? &source.heightMeters : nullptr);
  const TexelColouring colouring(source, request, rows);

  TextureTileResult result;
  result.image.sizeTexels = request.sizeTexels;
  result.image.format = TexelFormat::Rgba8;
  result.image.borderTexels = request.borderTexels;
  result.image.data.resize(textureTileDataBytes(request.sizeTexels, TexelFormat::Rgba8));

  rows.load(-1);
  rows.load(0);
  for (int y = 0; y < size; ++y) {
    rows.load(y + 1);
    // The texture error spans the inner texels only.
    if (y >= border && y < size - border) {
      const TexelRow* next = y + 1 < size - border ? &rows.row(y + 1) : nullptr;
      result.textureErrorMeters =
          std::max(result.textureErrorMeters,
                   largestSpacingInRow(rows, rows.row(y), next, border, size - border));
    }
    std::uint8_t* line =
        result.image.data.data() + static_cast<std::size_t>(y) * request.sizeTexels * 4;
    for (int x = 0; x < size; ++x) colouring.colour(x, y, line + static_cast<std::size_t>(x) * 4);
  }
  return result;
}

Result<TextureTileImage> buildNormalTile(const TextureSource& source,
                                         const TextureTileRequest& colour) {
  if (Result<void> valid = validateTextureTileRequest(colour); !valid) {
    return std::move(valid).error();
  }
  if (colour.sizeTexels % 2 != 0 || colour.borderTexels % 2 != 0 || colour.sizeTexels < 4) {
    return makeError(ErrorCode::InvalidArgument,
                     "normal-map tile: the colour tile's size " +
                         std::to_string(colour.sizeTexels) + " and border " +
                         std::to_string(colour.borderTexels) +
                         " must be even (the normal map is half as large)");
  }
  TextureTileRequest request = colour;
  request.sizeTexels /= 2;
  request.borderTexels /= 2;
  const bool haveHeights = static_cast<bool>(source.heightMeters);
  const int size = static_cast<int>(request.sizeTexels);
  TexelRows rows(source.planet, request, -1, size + 2, true,
                 haveHeights ? &source.heightMeters : nullptr);
  const ReliefSampler relief(source, rows);
  const CubeFace face = cubeFaceFromIndex(request.face);

  TextureTileImage tile;
  tile.sizeTexels = request.sizeTexels;
  tile.format = TexelFormat::Rg8;
  tile.borderTexels = request.borderTexels;
  tile.data.resize(textureTileDataBytes(request.sizeTexels, TexelFormat::Rg8));
  rows.load(-1);
  rows.load(0);
  for (int y = 0; y < size; ++y) {
    rows.load(y + 1);
    std::uint8_t* line = tile.data.data() + static_cast<std::size_t>(y) * request.sizeTexels * 2;
    for (int x = 0; x < size; ++x) {
      // The true relief's normal (no exaggeration: the renderer scales the slope it reads),
      // flat where the texel has no height.
      const GeodeticPosition& position = rows.row(y).positions[rows.column(x)];
      const LocalAxes axes = localAxes(position.latDegrees, position.lonDegrees);
      glm::dvec2 gradient(0.0);
      if (haveHeights) {
        const ReliefSample sample = relief.sample(x, y);
        if (sample.valid) gradient = sample.gradient;
      }
      const glm::dvec3 up = glm::cross(axes.east, axes.north);
      const glm::dvec3 normal =
          glm::normalize(up - gradient.x * axes.east - gradient.y * axes.north);
      const std::array<std::uint8_t, 2> texel = encodeNormalTexel(normalMapFrame(face, up), normal);
      const std::size_t at = 2 * static_cast<std::size_t>(x);
      line[at] = texel[0];
      line[at + 1] = texel[1];
    }
  }
  return tile;
}

std::function<std::optional<double>(double, double)> heightFunctionFromGrid(const HeightGrid& grid,
                                                                            bool bicubic) {
  if (bicubic) {
    return [&grid](double latDegrees, double lonDegrees) {
      return grid.sampleBicubic(latDegrees, lonDegrees);
    };
  }
  return [&grid](double latDegrees, double lonDegrees) {
    return grid.sampleBilinear(latDegrees, lonDegrees);
  };
}

}  // namespace pbdam::builder
