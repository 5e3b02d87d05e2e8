// Sine positional encoding of 3D keypoints (DReg-NeRF spec 4, as in REGTR and DETR): each axis is
// encoded separately with n = (d_model / 3) rounded down to an even number of features,
//   feature i of axis a = sin(x_a * scale / T^(2 floor(i/2) / n))  for even i,
//                         cos(x_a * scale / T^(2 floor(i/2) / n))  for odd i,
// the three axes are concatenated (x block, then y, then z) and zero-padded to d_model.
// Paper: d_model 256 -> 84 per axis + 4 zero columns, T = 1000, scale = 2 pi. The encoding uses
// each block's own coordinates, so it tells the transformer where a point lies inside its cloud,
// not how the clouds relate.
#pragma once

#include <torch/torch.h>

namespace nerfreg {

struct PositionalEncodingOptions {
  // Output width (the transformer's d); >= 6 so that every axis gets at least a sin/cos pair.
  int64_t d_model = 256;
  // Temperature T: the ratio between the lowest and highest frequency.
  double temperature = 1000.0;
  // Multiplies the coordinates before encoding (scene units -> radians).
  double scale = 2.0 * 3.14159265358979323846;

  // Features per axis: d_model / 3 rounded down to an even number.
  int64_t FeaturesPerAxis() const { return d_model / 3 / 2 * 2; }
  // Returns false (and logs why) when a field is out of range.
  bool Check() const;
};

// xyz: [N, 3] float32/float64 (N >= 0). Returns [N, d_model], same dtype and device. No
// parameters; differentiable in xyz (not needed: keypoint positions are data).
torch::Tensor SinePositionalEncoding(const torch::Tensor& xyz, const PositionalEncodingOptions& options);

}  // namespace nerfreg
