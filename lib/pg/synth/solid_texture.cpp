#include "pg/synth/solid_texture.h"

#include <array>
#include <cmath>

namespace pg::synth {
namespace {

// Cheap lattice hash: per-axis multiplies (hoisted by the caller) and one avalanche step.
inline float lattice(std::uint32_t hx, std::uint32_t hy, std::uint32_t hz, std::uint32_t seed) {
  std::uint32_t h = hx ^ hy ^ hz ^ seed;
  h ^= h >> 16;
  h *= 0x7feb352du;
  h ^= h >> 15;
  h *= 0x846ca68bu;
  h ^= h >> 16;
  return float(h & 0xFFFFFF) * (2.0f / float(0xFFFFFF)) - 1.0f;
}

inline float smooth(float t) {
  return t * t * t * (t * (t * 6 - 15) + 10);
}

}  // namespace

float value_noise(const Eigen::Vector3f& p, std::uint32_t seed) {
  float fx = std::floor(p.x()), fy = std::floor(p.y()), fz = std::floor(p.z());
  auto x0 = std::int32_t(fx), y0 = std::int32_t(fy), z0 = std::int32_t(fz);
  float tx = smooth(p.x() - fx), ty = smooth(p.y() - fy), tz = smooth(p.z() - fz);
  const std::uint32_t s = seed * 0x9E3779B1u;
  const std::uint32_t hx[2] = {std::uint32_t(x0) * 0x85EBCA77u, std::uint32_t(x0 + 1) * 0x85EBCA77u};
  const std::uint32_t hy[2] = {std::uint32_t(y0) * 0xC2B2AE3Du, std::uint32_t(y0 + 1) * 0xC2B2AE3Du};
  const std::uint32_t hz[2] = {std::uint32_t(z0) * 0x27D4EB2Fu, std::uint32_t(z0 + 1) * 0x27D4EB2Fu};
  float c[2][2][2];
  for (int dz = 0; dz < 2; ++dz)
    for (int dy = 0; dy < 2; ++dy)
      for (int dx = 0; dx < 2; ++dx) c[dz][dy][dx] = lattice(hx[dx], hy[dy], hz[dz], s);
  auto lerp = [](float a, float b, float t) { return a + (b - a) * t; };
  float y0v = lerp(lerp(c[0][0][0], c[0][0][1], tx), lerp(c[0][1][0], c[0][1][1], tx), ty);
  float y1v = lerp(lerp(c[1][0][0], c[1][0][1], tx), lerp(c[1][1][0], c[1][1][1], tx), ty);
  return lerp(y0v, y1v, tz);
}

float fbm(const Eigen::Vector3f& p, int octaves, std::uint32_t seed) {
  float sum = 0, amplitude = 0.5f, frequency = 1;
  for (int i = 0; i < octaves; ++i) {
    sum += amplitude * value_noise(p * frequency, seed + 101u * std::uint32_t(i));
    frequency *= 2.03f;  // not exactly 2, so octaves do not align on the lattice
    amplitude *= 0.5f;
  }
  return sum * 1.8f;
}

Eigen::Vector3f SolidTexture::albedo(const Eigen::Vector3f& p, int material) const {
  static const std::array<Eigen::Vector3f, 6> tints = {
      Eigen::Vector3f(0.80f, 0.72f, 0.60f),  // ground: sand
      Eigen::Vector3f(0.75f, 0.75f, 0.78f),  // wall: concrete
      Eigen::Vector3f(0.85f, 0.55f, 0.35f),  // box: wood
      Eigen::Vector3f(0.55f, 0.60f, 0.58f),  // rock
      Eigen::Vector3f(0.60f, 0.70f, 0.85f),  // cloth / misc
      Eigen::Vector3f(0.85f, 0.85f, 0.80f),  // plaster
  };
  const Eigen::Vector3f& tint = tints[std::size_t(material) % tints.size()];
  Eigen::Vector3f q = p / scale_;
  float broad = fbm(q, 3, seed_);
  float fine = fbm(q * 9.0f, 3, seed_ + 7);
  float speck = value_noise(q * 37.0f, seed_ + 13);
  float hue = value_noise(q * 2.0f, seed_ + 29);
  float v = 0.55f + 0.25f * broad + 0.15f * fine;
  if (speck > 0.55f)
    v *= 0.35f;  // dark speckles with sharp edges: corners for trackers
  else if (speck < -0.6f)
    v = std::min(1.0f, v * 1.5f);
  Eigen::Vector3f colour = tint * v;
  colour.x() *= 1.0f + 0.15f * hue;
  colour.z() *= 1.0f - 0.15f * hue;
  return colour.cwiseMax(0.0f).cwiseMin(1.0f);
}

}  // namespace pg::synth
