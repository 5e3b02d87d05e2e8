#pragma once
// Image quality metrics on RGB images in [0, 1]: PSNR, and SSIM with the usual 11x11 Gaussian
// window (sigma 1.5, C1 = 0.01^2, C2 = 0.03^2), averaged over channels.
#include "nerfreg/util/image.h"

namespace nerfreg {

// Throws std::invalid_argument when the images differ in size or channel count.
double Psnr(const Image& a, const Image& b);
double Ssim(const Image& a, const Image& b);

}  // namespace nerfreg
