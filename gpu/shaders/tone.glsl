// Radiance and display colour: the tone curve of the frame (exposure, 1 − e^−x, the sRGB transfer
// function) and its inverse, the sRGB decoding of texels. For atmosphere.glsl and tonemap.frag.

const float kPi = 3.14159265358979;

// Radiance to display: exposure, 1 − e^−x tone curve, the sRGB transfer function. Its two pieces
// are chosen per channel by selection, not blended: a blend by a 0/1 weight multiplies the piece
// not taken by 0, and lavapipe's pow(0, y) is NaN (black night pixels came out grey).
vec3 toneMap(vec3 radiance, float exposure) {
  const vec3 x = vec3(1.0) - exp(-max(radiance, vec3(0.0)) * exposure);
  return mix(12.92 * x, 1.055 * pow(x, vec3(1.0 / 2.4)) - 0.055,
             greaterThanEqual(x, vec3(0.0031308)));
}

// A texel's colour (sRGB-encoded) as linear reflectance.
vec3 srgbToLinear(vec3 c) {
  return mix(c / 12.92, pow((c + 0.055) / 1.055, vec3(2.4)), greaterThanEqual(c, vec3(0.04045)));
}

// srgbToLinear to within 0.6% of full scale, in three multiply-adds a channel instead of a power
// (a cubic fit; for the texels the patch fragments light, where the power was a tenth of a frame's
// work on lavapipe).
vec3 srgbToLinearFast(vec3 c) { return c * (c * (c * 0.305306011 + 0.682171111) + 0.012522878); }

// The radiance that toneMap() shows as the display colour `display` (its inverse): where the
// frame keeps radiance for a later tone map, the night side's floor (a share of the texel's
// display colour) is kept as the radiance that will show as it.
vec3 radianceShownAs(vec3 display, float exposure) {
  const vec3 x = min(srgbToLinear(clamp(display, vec3(0.0), vec3(1.0))), vec3(0.999999));
  return -log(vec3(1.0) - x) / exposure;
}
