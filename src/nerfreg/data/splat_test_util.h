#pragma once
// Random splat sets for tests: every field filled (normals and one extra property included), the
// log scales, opacities and SH coefficients in the ranges trained 3DGS files have.
#include <random>

#include "nerfreg/data/splat_ply.h"

namespace nerfreg {

inline Splats RandomSplats(std::int64_t n, int sh_degree, unsigned seed, bool normals = true) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> pos(-1.2f, 1.2f), scale(-5.f, -2.f), logit(-3.f, 5.f);
  std::normal_distribution<float> g(0.f, 1.f), sh(0.f, 0.2f);
  Splats s;
  s.Resize(n, sh_degree, normals);
  for (std::int64_t i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) {
      s.position(k, i) = pos(rng);
      if (normals) s.normal(k, i) = g(rng);
      s.f_dc(k, i) = g(rng);
      s.log_scale(k, i) = scale(rng);
    }
    for (int k = 0; k < s.f_rest.rows(); ++k) s.f_rest(k, i) = sh(rng);
    s.opacity(i) = logit(rng);
    for (int k = 0; k < 4; ++k) s.rotation(k, i) = g(rng);
  }
  SplatExtraProperty e{"label", "uchar", std::vector<double>(n)};
  for (std::int64_t i = 0; i < n; ++i) e.values[i] = static_cast<double>(i % 256);
  s.extras.push_back(e);
  return s;
}

}  // namespace nerfreg
