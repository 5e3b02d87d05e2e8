#include "nerfreg/render/blocks.h"

#include <algorithm>
#include <limits>
#include <stdexcept>

namespace nerfreg {

std::vector<int> KMeans(const std::vector<Eigen::Vector3d>& points, int k, unsigned seed, int iterations) {
  const int n = static_cast<int>(points.size());
  if (k < 1 || k > n) throw std::invalid_argument("KMeans: need 1 <= k <= number of points");
  std::mt19937 rng(seed);
  std::vector<Eigen::Vector3d> centres;
  centres.push_back(points[std::uniform_int_distribution<int>(0, n - 1)(rng)]);
  std::vector<double> d2(n);
  while (static_cast<int>(centres.size()) < k) {  // k-means++: far points are likelier centres
    double total = 0;
    for (int i = 0; i < n; ++i) {
      double best = std::numeric_limits<double>::infinity();
      for (const auto& c : centres) best = std::min(best, (points[i] - c).squaredNorm());
      d2[i] = best;
      total += best;
    }
    double r = std::uniform_real_distribution<double>(0, total)(rng);
    int pick = n - 1;
    for (int i = 0; i < n; ++i) {
      r -= d2[i];
      if (r <= 0) {
        pick = i;
        break;
      }
    }
    centres.push_back(points[pick]);
  }
  std::vector<int> label(n, 0);
  for (int it = 0; it < iterations; ++it) {
    bool changed = false;
    for (int i = 0; i < n; ++i) {
      int best = 0;
      for (int c = 1; c < k; ++c)
        if ((points[i] - centres[c]).squaredNorm() < (points[i] - centres[best]).squaredNorm()) best = c;
      changed |= best != label[i];
      label[i] = best;
    }
    for (int c = 0; c < k; ++c) {
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      int count = 0;
      for (int i = 0; i < n; ++i)
        if (label[i] == c) {
          sum += points[i];
          ++count;
        }
      if (count > 0) centres[c] = sum / count;
    }
    if (!changed && it > 0) break;
  }
  // Renumber by first appearance.
  std::vector<int> remap(k, -1);
  int next = 0;
  for (int i = 0; i < n; ++i)
    if (remap[label[i]] < 0) remap[label[i]] = next++;
  for (int& l : label) l = remap[l];
  return label;
}

void BlockFrameOptions::Check() const {
  if (max_translation < 0 || !(min_scale > 0) || max_scale < min_scale) {
    throw std::invalid_argument("BlockFrameOptions: translation must be >= 0 and 0 < min_scale <= max_scale");
  }
}

Sim3d RandomBlockFrame(const BlockFrameOptions& options, std::mt19937& rng) {
  options.Check();
  std::normal_distribution<double> g(0, 1);
  Vector6d xi;
  for (int k = 0; k < 6; ++k) xi(k) = g(rng);
  if (options.max_rotation_deg >= 0) {
    const double cap = options.max_rotation_deg * M_PI / 180.0;
    const double angle = xi.head<3>().norm();
    if (angle > cap && angle > 0) xi.head<3>() *= cap / angle;
  }
  Rigid3d t = Rigid3d::Exp(xi);
  for (int k = 0; k < 3; ++k)
    t.translation(k) = std::clamp(t.translation(k), -options.max_translation, options.max_translation);
  const double scale = options.max_scale > options.min_scale
                           ? std::uniform_real_distribution<double>(options.min_scale, options.max_scale)(rng)
                           : options.min_scale;
  return Sim3d(scale, t.rotation, t.translation);
}

}  // namespace nerfreg
