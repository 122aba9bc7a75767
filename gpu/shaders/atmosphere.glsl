// The atmosphere's precomputed tables (runtime/Atmosphere.h) and their lookups, for the patch
// vertex stage, sky.frag and sky_view.comp: the same parametrisations as the host's
// AtmosphereTables, in kilometres. The 4D scattering tables are 2D arrays with one layer per
// radius (the shader blends two layers and two ν slices). Descriptor set 4 of the patch pipeline
// layout (ATMOSPHERE_SET: set 0 of sky_view.comp's). Also the sky-view table's parametrisation.

#ifndef ATMOSPHERE_SET
#define ATMOSPHERE_SET 4
#endif
layout(set = ATMOSPHERE_SET, binding = 0) uniform sampler2D transmittanceTable;
layout(set = ATMOSPHERE_SET, binding = 1) uniform sampler2DArray scatteringTable;
layout(set = ATMOSPHERE_SET, binding = 2) uniform sampler2DArray singleMieTable;
layout(set = ATMOSPHERE_SET, binding = 3) uniform sampler2D irradianceTable;
layout(set = ATMOSPHERE_SET, binding = 4) uniform Atmosphere {
  vec4 solarIrradiance;  // xyz: at the top of the atmosphere; w: the sun's angular radius
  vec4 miePhaseG;        // xyz: Mie asymmetry per channel; w: cos of the largest sun zenith angle
  vec4 radii;            // x: bottom, y: top (km); z: ν size, w: μ_s size of the scattering table
  vec4 sizes;            // x: μ size, y: r size of the scattering table; z: 1 if there is one;
                         // w: the polar axis' stretch onto the bottom sphere
} atmosphere;

// A world direction or camera-relative offset in the atmosphere's space (the reference surface
// stretched along the polar axis onto the bottom sphere; camera-relative metres to km for offsets).
vec3 toAtmosphereDirection(vec3 v) { return normalize(vec3(v.xy, v.z * atmosphere.sizes.w)); }
vec3 toAtmosphereOffsetKm(vec3 v) { return vec3(v.xy, v.z * atmosphere.sizes.w) * 0.001; }

#include "tone.glsl"

float clampCosine(float mu) { return clamp(mu, -1.0, 1.0); }
float safeSqrt(float a) { return sqrt(max(a, 0.0)); }
float bottomRadius() { return atmosphere.radii.x; }
float topRadius() { return atmosphere.radii.y; }
float clampRadius(float r) { return clamp(r, bottomRadius(), topRadius()); }
float texCoord(float x, float size) { return 0.5 / size + x * (1.0 - 1.0 / size); }

float distanceToTop(float r, float mu) {
  return max(0.0, -r * mu + safeSqrt(r * r * (mu * mu - 1.0) + topRadius() * topRadius()));
}
float distanceToBottom(float r, float mu) {
  return max(0.0, -r * mu - safeSqrt(r * r * (mu * mu - 1.0) + bottomRadius() * bottomRadius()));
}
bool rayIntersectsGround(float r, float mu) {
  return mu < 0.0 && r * r * (mu * mu - 1.0) + bottomRadius() * bottomRadius() >= 0.0;
}

vec3 transmittanceToTop(float r, float mu) {
  const float h = sqrt(topRadius() * topRadius() - bottomRadius() * bottomRadius());
  const float rho = safeSqrt(r * r - bottomRadius() * bottomRadius());
  const float d = distanceToTop(r, mu);
  const float dMin = topRadius() - r;
  const float dMax = rho + h;
  const float xMu = dMax == dMin ? 0.0 : (d - dMin) / (dMax - dMin);
  const vec2 size = vec2(textureSize(transmittanceTable, 0));
  return texture(transmittanceTable, vec2(texCoord(xMu, size.x), texCoord(rho / h, size.y))).rgb;
}

vec3 transmittanceAlong(float r, float mu, float d, bool ground) {
  const float rD = clampRadius(sqrt(d * d + 2.0 * r * mu * d + r * r));
  const float muD = clampCosine((r * mu + d) / rD);
  if (ground) {
    return min(transmittanceToTop(rD, -muD) / transmittanceToTop(r, -mu), vec3(1.0));
  }
  return min(transmittanceToTop(r, mu) / transmittanceToTop(rD, muD), vec3(1.0));
}

vec3 transmittanceToSun(float r, float muS) {
  const float sinH = bottomRadius() / r;
  const float cosH = -safeSqrt(1.0 - sinH * sinH);
  const float a = sinH * atmosphere.solarIrradiance.w;
  return transmittanceToTop(r, muS) * smoothstep(-a, a, muS - cosH);
}

// (u: ν, v: μ_s, w: μ, z: r) of the scattering tables.
vec4 scatteringUvwz(float r, float mu, float muS, float nu, bool ground) {
  const float bottom = bottomRadius();
  const float h = sqrt(topRadius() * topRadius() - bottom * bottom);
  const float rho = safeSqrt(r * r - bottom * bottom);
  const float uR = texCoord(rho / h, atmosphere.sizes.y);
  const float rMu = r * mu;
  const float disc = rMu * rMu - r * r + bottom * bottom;
  const float halfMu = atmosphere.sizes.x * 0.5;
  float uMu;
  if (ground) {
    const float d = -rMu - safeSqrt(disc);
    const float dMin = r - bottom;
    const float dMax = rho;
    uMu = 0.5 - 0.5 * texCoord(dMax == dMin ? 0.0 : (d - dMin) / (dMax - dMin), halfMu);
  } else {
    const float d = -rMu + safeSqrt(disc + h * h);
    const float dMin = topRadius() - r;
    const float dMax = rho + h;
    uMu = 0.5 + 0.5 * texCoord((d - dMin) / (dMax - dMin), halfMu);
  }
  const float dMin = topRadius() - bottom;
  const float dMax = h;
  const float a = (distanceToTop(bottom, muS) - dMin) / (dMax - dMin);
  const float big = (distanceToTop(bottom, atmosphere.miePhaseG.w) - dMin) / (dMax - dMin);
  const float uMuS = texCoord(max(1.0 - a / big, 0.0) / (1.0 + a), atmosphere.radii.w);
  return vec4((nu + 1.0) * 0.5, uMuS, uMu, uR);
}

vec3 scatteringLookup(sampler2DArray table, float r, float mu, float muS, float nu,
                      bool ground) {
  const vec4 t = scatteringUvwz(r, mu, muS, nu, ground);
  const float nuSize = atmosphere.radii.z;
  const float x = t.x * (nuSize - 1.0);
  const float x0 = floor(x);
  const float lerpNu = x - x0;
  const float layers = atmosphere.sizes.y;
  const float layer = clamp(t.w * layers - 0.5, 0.0, layers - 1.0);
  const float l0 = floor(layer);
  const float l1 = min(l0 + 1.0, layers - 1.0);
  const float fl = layer - l0;
  const vec2 uv0 = vec2((x0 + t.y) / nuSize, t.z);
  const vec2 uv1 = vec2((x0 + 1.0 + t.y) / nuSize, t.z);
  const vec3 a = mix(texture(table, vec3(uv0, l0)).rgb, texture(table, vec3(uv0, l1)).rgb, fl);
  const vec3 b = mix(texture(table, vec3(uv1, l0)).rgb, texture(table, vec3(uv1, l1)).rgb, fl);
  // The tables end at the largest sun zenith angle they hold (μ_s min, clamped onto every lower
  // sun): the light fades to none over the last 0.02 of μ_s, so that the night side's air is dark.
  return mix(a, b, lerpNu) * smoothstep(atmosphere.miePhaseG.w, atmosphere.miePhaseG.w + 0.02, muS);
}

float rayleighPhase(float nu) { return 3.0 / (16.0 * kPi) * (1.0 + nu * nu); }

vec3 miePhase(float nu) {
  const vec3 g = atmosphere.miePhaseG.xyz;
  const vec3 k = 3.0 / (8.0 * kPi) * (1.0 - g * g) / (2.0 + g * g);
  const vec3 base = 1.0 + g * g - 2.0 * g * nu;
  return k * (1.0 + nu * nu) / (base * sqrt(base));
}

// The camera moved onto the top of the atmosphere along `ray` when above it; false when the ray
// misses the atmosphere.
bool enterAtmosphere(inout vec3 camera, vec3 ray, out float r, out float rmu) {
  r = length(camera);
  rmu = dot(camera, ray);
  const float toTop = -rmu - safeSqrt(rmu * rmu - r * r + topRadius() * topRadius());
  if (toTop > 0.0) {
    camera += ray * toTop;
    r = topRadius();
    rmu += toTop;
    return true;
  }
  return r <= topRadius();
}

// The sky's radiance along `ray` from `camera` (planet-centred, km); the transmittance to space.
vec3 skyRadiance(vec3 camera, vec3 ray, vec3 sun, out vec3 transmittance) {
  transmittance = vec3(1.0);
  float r;
  float rmu;
  if (!enterAtmosphere(camera, ray, r, rmu)) return vec3(0.0);
  r = clampRadius(r);
  const float mu = clampCosine(rmu / r);
  const float muS = clampCosine(dot(camera, sun) / r);
  const float nu = clampCosine(dot(ray, sun));
  const bool ground = rayIntersectsGround(r, mu);
  transmittance = ground ? vec3(0.0) : transmittanceToTop(r, mu);
  return scatteringLookup(scatteringTable, r, mu, muS, nu, ground) * rayleighPhase(nu) +
         scatteringLookup(singleMieTable, r, mu, muS, nu, ground) * miePhase(nu);
}

// The light scattered in towards `camera` between it and `point` (km), and the transmittance.
vec3 skyRadianceToPoint(vec3 camera, vec3 point, vec3 sun, out vec3 transmittance) {
  transmittance = vec3(1.0);
  const vec3 ray = normalize(point - camera);
  float r;
  float rmu;
  if (!enterAtmosphere(camera, ray, r, rmu)) return vec3(0.0);
  r = clampRadius(r);
  const float mu = clampCosine(rmu / r);
  const float muS = clampCosine(dot(camera, sun) / r);
  const float nu = clampCosine(dot(ray, sun));
  const float d = length(point - camera);
  const bool ground = rayIntersectsGround(r, mu);
  transmittance = transmittanceAlong(r, mu, d, ground);
  const float rP = clampRadius(sqrt(d * d + 2.0 * r * mu * d + r * r));
  const float muP = clampCosine((r * mu + d) / rP);
  const float muSP = clampCosine((r * muS + d * nu) / rP);
  const vec3 rayleigh = scatteringLookup(scatteringTable, r, mu, muS, nu, ground) -
                        transmittance * scatteringLookup(scatteringTable, rP, muP, muSP, nu, ground);
  const vec3 mie = scatteringLookup(singleMieTable, r, mu, muS, nu, ground) -
                   transmittance * scatteringLookup(singleMieTable, rP, muP, muSP, nu, ground);
  return max(rayleigh, vec3(0.0)) * rayleighPhase(nu) + max(mie, vec3(0.0)) * miePhase(nu);
}

// The sun's irradiance through the air (before the cosine with a surface's normal) and the
// sky's irradiance of a horizontal surface at `point` (km). A surface tilted by n sees the sky's
// share (1 + n·up) / 2 of the latter (Bruneton's approximation).
void sunAndSkyIrradiance(vec3 point, vec3 sun, out vec3 sunIrradiance, out vec3 skyIrradiance) {
  const float r = clampRadius(length(point));
  const vec3 up = point / length(point);
  const float muS = clampCosine(dot(up, sun));
  const vec2 size = vec2(textureSize(irradianceTable, 0));
  const float xR = (r - bottomRadius()) / (topRadius() - bottomRadius());
  const vec2 uv = vec2(texCoord(muS * 0.5 + 0.5, size.x), texCoord(xR, size.y));
  skyIrradiance = texture(irradianceTable, uv).rgb;
  sunIrradiance = atmosphere.solarIrradiance.xyz * transmittanceToSun(r, muS);
}

// The sky-view table (sky_view.comp writes it each frame, sky.frag reads it; Hillaire 2020): the
// sky's radiance from the frame's camera for every view direction, by its azimuth from the sun's
// (u: 0 towards the sun, 1 away; the sky is symmetric about the plane of the sun and the zenith)
// and its zenith angle (v: 0 at the zenith, or at the tangent to the top of the atmosphere from
// above it; 0.5 at the tangent to the ground, the horizon; 1 at the nadir), the square root of the
// angle from the horizon either side, so that texels crowd where the sky changes fastest: near
// the horizon, and along the limb from orbit.
struct SkyViewFrame {
  vec3 up;        // the camera's zenith
  vec3 towardsSun;  // the horizontal unit direction towards the sun (any one with the sun overhead)
  vec3 side;      // up × towardsSun
  float zenithTop;  // the zenith angle where the table starts (0 inside the atmosphere)
  float zenithHorizon;  // the zenith angle of the ground's tangent (π/2 at the ground or below)
};

SkyViewFrame skyViewFrame(vec3 camera, vec3 sun) {
  SkyViewFrame f;
  const float r = max(length(camera), bottomRadius());
  f.up = camera / length(camera);
  vec3 horizontal = sun - dot(sun, f.up) * f.up;
  if (dot(horizontal, horizontal) < 1e-12) {
    horizontal = abs(f.up.x) < 0.9 ? cross(f.up, vec3(1.0, 0.0, 0.0)) : cross(f.up, vec3(0.0, 1.0, 0.0));
  }
  f.towardsSun = normalize(horizontal);
  f.side = cross(f.up, f.towardsSun);
  f.zenithHorizon = kPi - asin(clamp(bottomRadius() / r, 0.0, 1.0));
  f.zenithTop = r > topRadius() ? kPi - asin(topRadius() / r) : 0.0;
  return f;
}

// The table coordinates of a unit view direction at zenith angle `zenith`.
vec2 skyViewUv(SkyViewFrame f, vec3 ray, float zenith) {
  const vec2 h = vec2(dot(ray, f.towardsSun), dot(ray, f.side));
  const float azimuth = dot(h, h) > 1e-12 ? abs(atan(h.y, h.x)) : 0.0;
  float v;
  if (zenith < f.zenithHorizon) {
    const float a = clamp((f.zenithHorizon - zenith) / max(f.zenithHorizon - f.zenithTop, 1e-6), 0.0, 1.0);
    v = 0.5 - 0.5 * sqrt(a);
  } else {
    const float b = clamp((zenith - f.zenithHorizon) / max(kPi - f.zenithHorizon, 1e-6), 0.0, 1.0);
    v = 0.5 + 0.5 * sqrt(b);
  }
  return vec2(azimuth / kPi, v);
}

// The unit view direction at table coordinates `uv` (skyViewUv's inverse).
vec3 skyViewRay(SkyViewFrame f, vec2 uv) {
  float zenith;
  if (uv.y < 0.5) {
    const float s = (0.5 - uv.y) * 2.0;
    zenith = f.zenithHorizon - s * s * (f.zenithHorizon - f.zenithTop);
  } else {
    const float s = (uv.y - 0.5) * 2.0;
    zenith = f.zenithHorizon + s * s * (kPi - f.zenithHorizon);
  }
  const float azimuth = uv.x * kPi;
  return f.up * cos(zenith) + (f.towardsSun * cos(azimuth) + f.side * sin(azimuth)) * sin(zenith);
}
