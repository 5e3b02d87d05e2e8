#pragma once
// Dot products of 128-float rows through the BLAS (OpenBLAS where scripts/setup.sh installed it):
// its kernels use the CPU's widest vectors, where Eigen's own products have SSE2 only (the build
// targets baseline x86-64). Shared by the SIFT matcher and the pair selection's vocabulary tree.

namespace nerfreg {

// out[j * na + i] = a_i . b_j for the rows a_i of a (na x 128, row-major) and b_j of b (nb x 128,
// row-major): a column-major na x nb matrix, one sgemm.
void DotProducts128(const float* a, int na, const float* b, int nb, float* out);

}  // namespace nerfreg
