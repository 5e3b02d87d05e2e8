#include "nerfreg/viewgraph/descriptor_product.h"

// The Fortran BLAS's single-precision product (any libblas.so.3; threads set by exe/main.cc):
// C = op(A) op(B), column-major.
extern "C" void sgemm_(const char* transa, const char* transb, const int* m, const int* n, const int* k,
                       const float* alpha, const float* a, const int* lda, const float* b, const int* ldb,
                       const float* beta, float* c, const int* ldc);

namespace nerfreg {

void DotProducts128(const float* a, int na, const float* b, int nb, float* out) {
  if (na <= 0 || nb <= 0) return;
  const char transpose = 'T', keep = 'N';
  const int depth = 128;
  const float one = 1, zero = 0;
  sgemm_(&transpose, &keep, &na, &nb, &depth, &one, a, &depth, b, &depth, &zero, out, &na);
}

}  // namespace nerfreg
