#pragma once
// Inside the sim plugin: the world's independent random streams and the draws every part makes
// from them. Draws use the raw engine output only, so a run is the same with any standard
// library. The world seeds the streams; a part draws only from the stream it is handed.
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>

#include "projtour/contract/geometry.hpp"

namespace projtour::sim {

// Independent random streams, so e.g. grabbing one more frame does not change the laser noise.
// New streams go at the end: the others' seeds, and so every existing run, stay as they were.
enum class Stream : std::uint64_t {
  setup = 1,
  odometry,
  laser,
  encoder,
  depth,
  faults,
  colour,
  building,
  people
};

inline std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

inline std::mt19937_64 stream(std::uint64_t seed, Stream s) {
  return std::mt19937_64(splitmix64(seed * 0x100000001B3ull + static_cast<std::uint64_t>(s)));
}

inline double uniform(std::mt19937_64& rng, double lo, double hi) {
  return lo + (hi - lo) * static_cast<double>(rng() >> 11) * 0x1.0p-53;
}

inline double gaussian(std::mt19937_64& rng) {
  // Box-Muller on the raw engine output: reproducible across standard libraries.
  const double u1 = (static_cast<double>(rng() >> 11) + 0.5) * 0x1.0p-53;
  const double u2 = static_cast<double>(rng() >> 11) * 0x1.0p-53;
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
}

inline Eigen::Vector3d random_unit(std::mt19937_64& rng) {
  const double z = uniform(rng, -1.0, 1.0), phi = uniform(rng, 0.0, 2.0 * kPi);
  const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
  return {r * std::cos(phi), r * std::sin(phi), z};
}

}  // namespace projtour::sim
