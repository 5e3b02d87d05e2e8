#pragma once
// Focal length from fundamental matrices (self-calibration for photos without a calibration file,
// as GLOMAP's view-graph calibration): with the right intrinsics K, E = K^T F K is an essential
// matrix, whose two non-zero singular values are equal. The focal length (one per camera group,
// principal point at the image centre) is the one that makes them most equal over the group's
// pairs: the median over pairs of (s1 - s2) / (s1 + s2), minimised over a logarithmic grid of
// focal lengths and refined by golden-section search.
//
// The criterion is flat when the cameras' optical axes meet in one point (an orbit aimed at an
// object's centre is close to that: Bougnoux's degeneracy), so the estimate says whether its
// minimum is distinct; an undistinct one is left to the bundle adjustment to refine from the
// prior.
#include <Eigen/Core>
#include <vector>

namespace nerfreg {

struct FocalEstimationOptions {
  double min_fraction = 0.3;  // search range, as fractions of the image's longer side
  double max_fraction = 5.0;
  int grid_steps = 120;  // logarithmic grid over the range
  // The minimum is distinct when the cost at focal / 1.3 and focal * 1.3 both exceed the minimum
  // by this factor (and the minimum is inside the range).
  double distinct_ratio = 1.5;
  int min_pairs = 3;   // fewer fundamental matrices: no estimate
  void Check() const;  // throws std::invalid_argument
};

struct FocalEstimate {
  double focal_px = 0;  // the minimiser (0 with too few pairs)
  double cost = 0;      // the median criterion there
  bool distinct = false;
  int num_pairs = 0;
};

// j_F_i: fundamental matrices in pixels (x_j^T F x_i = 0) of pairs of images that share one
// camera of the given size (principal point at the centre).
FocalEstimate EstimateFocalFromFundamentals(const std::vector<Eigen::Matrix3d>& j_F_i, int width, int height,
                                            const FocalEstimationOptions& options = {});

// The criterion for one pair at one focal length (for tests): (s1 - s2) / (s1 + s2) of K^T F K.
double EssentialSingularValueGap(const Eigen::Matrix3d& j_F_i, double focal_px, double cx, double cy);

}  // namespace nerfreg
