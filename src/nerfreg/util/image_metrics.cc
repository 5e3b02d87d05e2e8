#include "nerfreg/util/image_metrics.h"

#include <cmath>
#include <stdexcept>
#include <vector>

namespace nerfreg {
namespace {
void CheckSame(const Image& a, const Image& b) {
  if (a.width != b.width || a.height != b.height || a.channels != b.channels || a.empty()) {
    throw std::invalid_argument("image metrics: images differ in size or channels");
  }
}
}  // namespace

double Psnr(const Image& a, const Image& b) {
  CheckSame(a, b);
  double mse = 0;
  for (size_t i = 0; i < a.data.size(); ++i) mse += std::pow(double(a.data[i]) - b.data[i], 2);
  mse /= a.data.size();
  return mse > 0 ? -10.0 * std::log10(mse) : 100.0;
}

double Ssim(const Image& a, const Image& b) {
  CheckSame(a, b);
  const int r = 5;
  std::vector<double> g(2 * r + 1);
  double gs = 0;
  for (int k = -r; k <= r; ++k) gs += g[k + r] = std::exp(-k * k / (2 * 1.5 * 1.5));
  for (double& v : g) v /= gs;
  const double c1 = 1e-4, c2 = 9e-4;
  const int w = a.width, h = a.height;
  double total = 0;
  int count = 0;
  // Separable Gaussian filtering of x, y, x^2, y^2, xy over the valid region.
  for (int c = 0; c < a.channels; ++c) {
    std::vector<double> maps[5], tmp[5];
    for (int m = 0; m < 5; ++m) {
      maps[m].assign(size_t(w) * h, 0);
      tmp[m].assign(size_t(w) * h, 0);
    }
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const double u = a.at(x, y, c), v = b.at(x, y, c);
        const double vals[5] = {u, v, u * u, v * v, u * v};
        for (int m = 0; m < 5; ++m) maps[m][size_t(y) * w + x] = vals[m];
      }
    for (int m = 0; m < 5; ++m)
      for (int y = 0; y < h; ++y)
        for (int x = r; x < w - r; ++x) {
          double s = 0;
          for (int k = -r; k <= r; ++k) s += g[k + r] * maps[m][size_t(y) * w + x + k];
          tmp[m][size_t(y) * w + x] = s;
        }
    for (int y = r; y < h - r; ++y)
      for (int x = r; x < w - r; ++x) {
        double f[5];
        for (int m = 0; m < 5; ++m) {
          double s = 0;
          for (int k = -r; k <= r; ++k) s += g[k + r] * tmp[m][size_t(y + k) * w + x];
          f[m] = s;
        }
        const double mu1 = f[0], mu2 = f[1];
        const double s1 = f[2] - mu1 * mu1, s2 = f[3] - mu2 * mu2, s12 = f[4] - mu1 * mu2;
        total += ((2 * mu1 * mu2 + c1) * (2 * s12 + c2)) / ((mu1 * mu1 + mu2 * mu2 + c1) * (s1 + s2 + c2));
        ++count;
      }
  }
  if (count == 0) throw std::invalid_argument("Ssim: images smaller than the 11x11 window");
  return total / count;
}

}  // namespace nerfreg
