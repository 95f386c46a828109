#pragma once
// Procedural solid textures: colour as a function of the 3-D surface point, so synthetic images have
// detail at every scale without UV seams. Deterministic for a seed.
#include <Eigen/Core>
#include <cstdint>

namespace pg::synth {

// Smooth 3-D value noise in [-1, 1] on an integer lattice hashed with `seed`.
float value_noise(const Eigen::Vector3f& p, std::uint32_t seed);
// Fractal sum of `octaves` value-noise layers (lacunarity 2, gain 0.5), roughly in [-1, 1].
float fbm(const Eigen::Vector3f& p, int octaves, std::uint32_t seed);

// A rich, trackable texture: blotches at several scales, sharp-edged speckles and a tint per material.
// `scale` is the size of the largest features in scene units.
class SolidTexture {
 public:
  SolidTexture(std::uint32_t seed, float scale) : seed_(seed), scale_(scale) {}
  // Linear RGB albedo in [0, 1] at `p`; `material` tints it.
  Eigen::Vector3f albedo(const Eigen::Vector3f& p, int material) const;

 private:
  std::uint32_t seed_;
  float scale_;
};

}  // namespace pg::synth
