#include "nerfreg/viewgraph/view_graph.h"

#include <algorithm>
#include <limits>
#include <cmath>
#include <cstdlib>
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <oneapi/dnnl/dnnl.h>
#include <optional>
#include <stdexcept>

#include "nerfreg/geometry/rigid3.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/omp_threads.h"
#include "nerfreg/util/timer.h"
#include "nerfreg/viewgraph/descriptor_product.h"
#include "nerfreg/viewgraph/two_view_refinement.h"

namespace nerfreg {

int EffectiveUpsample(const ViewGraphOptions& options, int max_side) {
  if (options.upsample <= 1 || options.upsample_max_side <= 0) return options.upsample;
  return max_side > 0 && max_side * options.upsample <= options.upsample_max_side ? options.upsample : 1;
}

TwoViewEstimator ParseTwoViewEstimator(const std::string& name) {
  if (name == "ransac") return TwoViewEstimator::kRansac;
  if (name == "usac") return TwoViewEstimator::kUsac;
  ThrowInputError("--two-view", "", "ransac or usac, got '" + name + "'");
}

std::string TwoViewEstimatorName(TwoViewEstimator estimator) {
  return estimator == TwoViewEstimator::kUsac ? "usac" : "ransac";
}

SiftNormalization ParseSiftNormalization(const std::string& name) {
  if (name == "l1-root") return SiftNormalization::kL1Root;
  if (name == "l2") return SiftNormalization::kL2;
  ThrowInputError("--sift-normalization", "", "l1-root or l2, got '" + name + "'");
}

std::string SiftNormalizationName(SiftNormalization normalization) {
  return normalization == SiftNormalization::kL1Root ? "l1-root" : "l2";
}

void ViewGraphOptions::Check() const {
  // Named by the command-line options that set them (dbarf poses), since users set them there.
  if (max_features <= 0) ThrowInputError("--max-features", "", "> 0, got " + std::to_string(max_features));
  if (!(ratio > 0 && ratio < 1)) ThrowInputError("ratio", "", "in (0, 1)");
  if (!(ransac_threshold_px > 0)) ThrowInputError("ransac_threshold_px", "", "> 0");
  if (!(ransac_confidence > 0 && ransac_confidence < 1)) ThrowInputError("ransac_confidence", "", "in (0, 1)");
  if (min_inliers < 5)
    ThrowInputError("--min-inliers", "", ">= 5 (an essential matrix needs 5), got " + std::to_string(min_inliers));
  if (!(contrast_threshold > 0)) ThrowInputError("--sift-contrast", "", "> 0");
  if (!(sparse_contrast_threshold >= 0)) ThrowInputError("--sift-contrast-sparse", "", ">= 0 (0: never)");
  if (sparse_image_keypoints < 0)
    ThrowInputError("--sift-sparse-keypoints", "", ">= 0, got " + std::to_string(sparse_image_keypoints));
  if (upsample < 1 || upsample > 4) ThrowInputError("--sift-upsample", "", "1..4, got " + std::to_string(upsample));
  if (upsample_max_side < 0)
    ThrowInputError("--sift-upsample-max-side", "", ">= 0, got " + std::to_string(upsample_max_side));
  pairs.Check();
}

std::vector<int> ViewGraph::Neighbors(int i, int k) const {
  std::vector<std::pair<int, int>> scored;  // inliers, other
  for (const auto& e : edges) {
    if (e.i == i) scored.push_back({e.num_inliers, e.j});
    if (e.j == i) scored.push_back({e.num_inliers, e.i});
  }
  std::sort(scored.begin(), scored.end(),
            [](auto a, auto b) { return a.first != b.first ? a.first > b.first : a.second < b.second; });
  std::vector<int> out;
  for (int n = 0; n < static_cast<int>(scored.size()) && n < k; ++n) out.push_back(scored[n].second);
  return out;
}

std::vector<int> ViewGraph::Isolated() const {
  std::vector<bool> linked(names.size(), false);
  for (const auto& e : edges) linked[e.i] = linked[e.j] = true;
  std::vector<int> out;
  for (size_t k = 0; k < names.size(); ++k)
    if (!linked[k]) out.push_back(static_cast<int>(k));
  return out;
}

const ViewGraphEdge* ViewGraph::FindEdge(int i, int j) const {
  for (const auto& e : edges)
    if ((e.i == i && e.j == j) || (e.i == j && e.j == i)) return &e;
  return nullptr;
}

namespace {

// A homography with more than this share of the essential matrix's inliers makes a pair planar or
// panoramic (COLMAP's max_H_inlier_ratio).
constexpr double kPlanarInlierRatio = 0.8;
// ... and panoramic (no translation direction) when its inlier rays, rotated by the homography's
// rotation, differ by less than this median angle.
constexpr double kPanoramicParallaxDeg = 0.5;
// ... and is not tried where the essential matrix's rotations leave this median angle (4x the
// above: a margin for the rotation the homography would find being that far from theirs).
constexpr double kPanoramicScreenDeg = 2.0;
// The most the refinement of a relative pose gains (RelativePoseCost, Cauchy) from the true pose
// on noise alone: 0.55 with 150 matches at 0.25 px (view_graph_test.cc), a margin above that.
constexpr double kRefinementNoiseGain = 2.0;
// A homography fitted with few hypotheses is fitted again with the full cap where its rotation
// leaves the median ray within this (2x the panoramic cut).
constexpr double kFarRefitDeg = 1.0;

// The median angle (degrees, the upper median) between the rays of the masked matches once those of
// image i are rotated by j_from_i.
double MedianParallaxDeg(const std::vector<cv::Point2d>& pi, const std::vector<cv::Point2d>& pj, const cv::Mat& mask,
                         const Eigen::Matrix3d& j_from_i) {
  std::vector<double> angles;
  for (size_t m = 0; m < pi.size(); ++m) {
    if (mask.at<uint8_t>(static_cast<int>(m)) == 0) continue;
    const Eigen::Vector3d a = j_from_i * Eigen::Vector3d(pi[m].x, pi[m].y, 1), b(pj[m].x, pj[m].y, 1);
    angles.push_back(std::atan2(a.cross(b).norm(), a.dot(b)) * 180 / M_PI);
  }
  if (angles.empty()) return 0;
  std::nth_element(angles.begin(), angles.begin() + angles.size() / 2, angles.end());
  return angles[angles.size() / 2];
}

// Whether the essential matrix's pose (rot, trans) rules out that the pair is panoramic: both of
// its rotations (the chosen one and its twisted pair, 180 deg about the translation) leave the
// median inlier ray kPanoramicScreenDeg or more from its match, so only a rotation at least
// kPanoramicScreenDeg - kPanoramicParallaxDeg away from both could bring it within
// kPanoramicParallaxDeg.
bool PanoramicRuledOut(const std::vector<cv::Point2d>& pi, const std::vector<cv::Point2d>& pj, const cv::Mat& mask,
                       const Eigen::Matrix3d& rot, const Eigen::Vector3d& trans) {
  const Eigen::Vector3d t = trans.normalized();
  const Eigen::Matrix3d twisted = (2 * t * t.transpose() - Eigen::Matrix3d::Identity()) * rot;
  return MedianParallaxDeg(pi, pj, mask, rot) >= kPanoramicScreenDeg &&
         MedianParallaxDeg(pi, pj, mask, twisted) >= kPanoramicScreenDeg;
}

// The pose refined on its inliers (RefineRelativePose), then the inliers chosen again among all
// matches (Sampson distance within the threshold, in front of both cameras), until they stay the
// same (at most 3 rounds). A refined pose that cheirality would decompose otherwise is not taken.
// Returns the inlier count; in_front: (N) of the N matches, the inliers, updated with the pose.
int RefineOnInliers(const std::vector<Eigen::Vector2d>& all_i, const std::vector<Eigen::Vector2d>& all_j,
                    double threshold, int inliers, Eigen::Matrix3d* rot, Eigen::Vector3d* trans,
                    std::vector<uint8_t>* in_front) {
  const int num_matches = static_cast<int>(all_i.size());
  for (int round = 0; round < 3 && inliers >= 5; ++round) {
    std::vector<Eigen::Vector2d> xi, xj;
    for (int m = 0; m < num_matches; ++m)
      if ((*in_front)[m] != 0) xi.push_back(all_i[m]), xj.push_back(all_j[m]);
    Eigen::Matrix3d rot_refined = *rot;
    Eigen::Vector3d trans_refined = *trans;
    RefineRelativePose(xi, xj, threshold, &rot_refined, &trans_refined);
    const Eigen::Matrix3d e_refined = Skew(trans_refined) * rot_refined;
    std::vector<uint8_t> refined(num_matches);
    for (int m = 0; m < num_matches; ++m)
      refined[m] = std::abs(SampsonDistance(e_refined, all_i[m], all_j[m])) < threshold;
    Eigen::Matrix3d r_check;
    Eigen::Vector3d t_check;
    const int refined_inliers = RecoverPoseFromEssential(e_refined, all_i, all_j, &refined, &r_check, &t_check);
    // The decomposition of e_refined chosen by cheirality; where it is another one than the
    // refined pose, the refinement went astray: keep the pose before it.
    if ((r_check - rot_refined).norm() > 1e-6 || (t_check - trans_refined).norm() > 1e-6 || refined_inliers < 5) break;
    const bool same = refined == *in_front;
    *rot = rot_refined, *trans = trans_refined, *in_front = refined, inliers = refined_inliers;
    if (same) break;
  }
  return inliers;
}

// The relative pose a planar scene's homography h (x_j ~ h x_i, normalised coordinates) gives:
// among cv::decomposeHomographyMat's solutions, the one whose essential matrix [t]x R has the most
// matches within `threshold` (Sampson) and in front of both cameras (COLMAP's
// PoseFromHomographyMatrix chooses by the points in front too). Returns that count (0: none);
// mask: (N) of the N matches, those counted.
int PoseFromHomography(const cv::Mat& h, const std::vector<Eigen::Vector2d>& xi, const std::vector<Eigen::Vector2d>& xj,
                       double threshold, Eigen::Matrix3d* rot, Eigen::Vector3d* trans, std::vector<uint8_t>* mask) {
  std::vector<cv::Mat> rotations, translations, normals;
  cv::decomposeHomographyMat(h, cv::Mat::eye(3, 3, CV_64F), rotations, translations, normals);
  int best = 0;
  for (size_t k = 0; k < rotations.size(); ++k) {
    Eigen::Matrix3d r;
    Eigen::Vector3d t;
    cv::cv2eigen(rotations[k], r);
    cv::cv2eigen(translations[k], t);
    if (t.norm() < 1e-12) continue;  // a pure rotation: the panoramic case's
    const Eigen::Matrix3d e = Skew(t.normalized()) * r;
    std::vector<uint8_t> within(xi.size());
    for (size_t m = 0; m < xi.size(); ++m) within[m] = std::abs(SampsonDistance(e, xi[m], xj[m])) < threshold;
    Eigen::Matrix3d r_check;
    Eigen::Vector3d t_check;
    const int count = RecoverPoseFromEssential(e, xi, xj, &within, &r_check, &t_check);
    // Cheirality may pick another of e's decompositions than the homography's own: not this one.
    if ((r_check - r).norm() > 1e-6 || count <= best) continue;
    best = count, *rot = r, *trans = t_check, *mask = std::move(within);
  }
  return best;
}

// Hypotheses drawn at most (OpenCV's defaults for the essential matrix and the homography).
constexpr int kMaxEssentialIterations = 1000;
constexpr int kMaxHomographyIterations = 2000;
// ... and for the homography with early rejection. Its costly fits are the refits of pairs whose
// essential matrix has its inliers beyond the cheirality test's depth (short baselines, below): at 2000 hypotheses 239
// such fits took 10.3 of the 28 CPU s of the two-view geometry on 192 forward-facing views, for 50 panoramic edges. At
// 500: 34.1 -> 30.7 s, median rotation error 0.0890 -> 0.0903 deg (96 views: 15.1 -> 14.5 s, 0.0909 -> 0.0904); not
// fitting them again at all: 28.8 s but 0.0951 deg. The real sets of bench/real_poses.sh are unchanged.
constexpr int kMaxEarlyHomographyIterations = 500;

// The hypotheses that find, with probability `confidence`, an all-inlier sample of `sample_size`
// among num_matches matches when min_inliers of them are inliers: a model with fewer inliers is
// no edge, so more hypotheses than this only search for models that would be rejected.
int RansacIterationCap(int num_matches, int min_inliers, int sample_size, double confidence, int max_iterations) {
  if (num_matches <= min_inliers) return 1;
  double p_all_inliers = 1;  // drawn without replacement
  for (int k = 0; k < sample_size; ++k) p_all_inliers *= std::max(0.0, double(min_inliers - k) / (num_matches - k));
  if (p_all_inliers <= 0) return max_iterations;
  const double n = std::ceil(std::log(1 - confidence) / std::log(1 - p_all_inliers));
  return static_cast<int>(std::clamp(n, 1.0, static_cast<double>(max_iterations)));
}

template <typename ImageT>
cv::Mat ToGray8(const ImageT& im) {
  cv::Mat gray(im.height, im.width, CV_8UC1);
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x)
      gray.at<uint8_t>(y, x) = static_cast<uint8_t>(std::clamp(FeatureGrey(im, x, y), 0.f, 1.f) * 255.f + 0.5f);
  return gray;
}

// Mutual nearest neighbours passing the ratio test in both directions, from one matrix of
// descriptor dot products (one GEMM instead of two brute-force passes):
// |a - b|^2 = |a|^2 + |b|^2 - 2 a.b. The product is column-major, so each column (one keypoint
// of b against every keypoint of a) is contiguous: a's running best two are updated without
// branches (the compiler vectorises it), and b's best two are one pass over the column.
// The best two distances of one keypoint of b over every row of a, and the row of the best (the
// first such row on ties).
template <typename T>
struct ColumnBest {
  T c1 = std::numeric_limits<T>::max(), c2 = std::numeric_limits<T>::max();
  int i1 = -1;
};

// One column of squared distances d_i = |a_i|^2 + |b_j|^2 - 2 a_i.b_j, read once: updates each row's
// running best two (d1, d2, j1) and returns the column's best two. The column's search keeps
// kLanes independent best-two lanes (row i in lane i % kLanes) so that both updates are branchless
// and vectorise, then merges the lanes; the result equals the sequential search's exactly.
// T: float (the BLAS product) or int32_t (oneDNN's integer product); the distances are the same
// integers in both (below 2^24, so exact in float), and so are the matches. The rows' arrays are
// declared unaliased: with T = int32_t, j1 could otherwise alias d1 and d2 and GCC would not
// vectorise the updates.
constexpr int kLanes = 16;
template <typename T>
inline __attribute__((always_inline)) ColumnBest<T> ScanColumnBody(const T* __restrict column,
                                                                   const T* __restrict norms_a, T norm_b, int na, int j,
                                                                   T* __restrict d1, T* __restrict d2,
                                                                   int* __restrict j1) {
  constexpr T kFar = std::numeric_limits<T>::max();
  T c1[kLanes], c2[kLanes];
  int i1[kLanes];
  for (int l = 0; l < kLanes; ++l) c1[l] = c2[l] = kFar, i1[l] = -1;
  const auto update = [&](int i, int l) {
    const T d = norms_a[i] + norm_b - 2 * column[i];
    const bool row_better = d < d1[i];
    d2[i] = row_better ? d1[i] : std::min(d2[i], d);
    j1[i] = row_better ? j : j1[i];
    d1[i] = row_better ? d : d1[i];
    const bool better = d < c1[l];
    c2[l] = better ? c1[l] : std::min(c2[l], d);
    i1[l] = better ? i : i1[l];
    c1[l] = better ? d : c1[l];
  };
  int base = 0;
  for (; base + kLanes <= na; base += kLanes)
    for (int l = 0; l < kLanes; ++l) update(base + l, l);
  for (int l = 0; base + l < na; ++l) update(base + l, l);
  int best = 0;
  for (int l = 1; l < kLanes; ++l)
    if (c1[l] < c1[best] || (c1[l] == c1[best] && i1[l] >= 0 && (i1[best] < 0 || i1[l] < i1[best]))) best = l;
  ColumnBest<T> out;
  out.c1 = c1[best];
  out.i1 = i1[best];
  out.c2 = c2[best];
  for (int l = 0; l < kLanes; ++l)
    if (l != best) out.c2 = std::min(out.c2, c1[l]);
  return out;
}

// The body inlined into one function per element type, each built for AVX-512, AVX2 and baseline
// x86-64 and chosen at run time (the build targets baseline x86-64; Clang takes no function
// template with target_clones).
#if defined(__x86_64__) && (defined(__clang__) || defined(__GNUC__))
#define NERFREG_SCAN_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
#else
#define NERFREG_SCAN_CLONES
#endif
NERFREG_SCAN_CLONES ColumnBest<float> ScanColumn(const float* __restrict column, const float* __restrict norms_a,
                                                 float norm_b, int na, int j, float* __restrict d1,
                                                 float* __restrict d2, int* __restrict j1) {
  return ScanColumnBody<float>(column, norms_a, norm_b, na, j, d1, d2, j1);
}
NERFREG_SCAN_CLONES ColumnBest<int32_t> ScanColumn(const int32_t* __restrict column, const int32_t* __restrict norms_a,
                                                   int32_t norm_b, int na, int j, int32_t* __restrict d1,
                                                   int32_t* __restrict d2, int* __restrict j1) {
  return ScanColumnBody<int32_t>(column, norms_a, norm_b, na, j, d1, d2, j1);
}
#undef NERFREG_SCAN_CLONES

// Caps oneDNN's instruction set at AVX-512 VNNI unless ONEDNN_MAX_CPU_ISA or DNNL_MAX_CPU_ISA is
// set. On CPUs with AMX (Xeon Sapphire Rapids and later) its u8 x s8 GEMM otherwise dispatches the
// matcher's products (blocks of 256 columns, a few thousand rows, depth 128) to AMX kernels, 3.3x
// slower there than its VNNI ones (matching of ViSP's cube: 9.9-10.4 -> 3.0-3.1 s). The cap holds
// only if set before oneDNN's first read of it (asking for the effective ISA is one): the matcher
// sets it before its first product, which in `dbarf poses` comes before any LibTorch kernel
// (LibTorch shares the library; its float kernels do not use AMX). A cap above what the CPU has
// changes nothing, so it needs no test of the CPU.
void CapOneDnnBelowAmx() {
  if (std::getenv("ONEDNN_MAX_CPU_ISA") != nullptr || std::getenv("DNNL_MAX_CPU_ISA") != nullptr) return;
  dnnl_set_max_cpu_isa(dnnl_cpu_isa_avx512_core_vnni);  // fails, harmlessly, once oneDNN has read it
}

// Whether oneDNN's u8 x s8 product gives exact 32-bit sums on this CPU. With VNNI (vpdpbusd) it
// does; without, oneDNN's int8 kernels add pairs of products in saturating 16-bit sums (vpmaddubsw;
// its "int8 computations" guide), which SIFT's bytes overflow (255 x 127 x 2 > 32767). Checked once
// on a product that saturates there, so a CPU without VNNI takes the float product and gets the
// same matches.
}  // namespace

bool Int8DescriptorProductIsExact() {
  static const bool exact = [] {
    CapOneDnnBelowAmx();
    const unsigned isa = static_cast<unsigned>(dnnl_get_effective_cpu_isa());
    const unsigned vnni = static_cast<unsigned>(dnnl_cpu_isa_avx512_core_vnni);
    if ((isa & vnni) != vnni) return false;
    constexpr int kSide = 64, kDepth = 128;
    const std::vector<uint8_t> a(kSide * kDepth, 255);
    const std::vector<int8_t> b(kSide * kDepth, 127);
    std::vector<int32_t> c(kSide * kSide, 0);
    const int32_t offset = 0;
    const ScopedOmpThreads one_thread(1);
    if (dnnl_gemm_u8s8s32('N', 'T', 'F', kSide, kSide, kDepth, 1.f, a.data(), kDepth, 0, b.data(), kDepth, 0, 0.f,
                          c.data(), kSide, &offset) != dnnl_success) {
      return false;
    }
    return std::all_of(c.begin(), c.end(), [](int32_t v) { return v == kDepth * 255 * 127; });
  }();
  return exact;
}

namespace {

// Matches from the column-major products of a's rows with blocks of kColumnBlock rows of b:
// `product(j0, columns, dot)` writes a_i.b_j (as T) for j in [j0, j0 + columns) into
// dot[(j - j0) * na + i]; norms_a[i] + norm_b(j) - 2 dot is the squared distance.
template <typename T, typename Product, typename NormB>
std::vector<std::pair<int, int>> MutualRatioMatches(int na, int nb, const std::vector<T>& norms_a, NormB norm_b,
                                                    double ratio, Product product) {
  constexpr int kColumnBlock = 256;
  // This thread's buffer, kept between calls: a fresh na x nb product (64 MB at 4000 keypoints)
  // cost as much in page faults as the product itself.
  thread_local std::vector<T> dot;
  dot.resize(static_cast<size_t>(na) * std::min(nb, kColumnBlock));
  constexpr T kFar = std::numeric_limits<T>::max();
  const float r2 = static_cast<float>(ratio * ratio);
  std::vector<T> d1a(na, kFar), d2a(na, kFar);
  std::vector<int> j1a(na, -1), best_ba(nb, -1);
  for (int j0 = 0; j0 < nb; j0 += kColumnBlock) {
    const int columns = std::min(kColumnBlock, nb - j0);
    product(j0, columns, dot.data());
    for (int c = 0; c < columns; ++c) {
      const int j = j0 + c;
      const ColumnBest<T> best = ScanColumn(dot.data() + static_cast<size_t>(c) * na, norms_a.data(), norm_b(j), na, j,
                                            d1a.data(), d2a.data(), j1a.data());
      if (best.i1 >= 0 && static_cast<float>(best.c1) < r2 * static_cast<float>(best.c2)) best_ba[j] = best.i1;
    }
  }
  std::vector<std::pair<int, int>> out;
  for (int i = 0; i < na; ++i) {
    const int j = j1a[i];
    if (j >= 0 && static_cast<float>(d1a[i]) < r2 * static_cast<float>(d2a[i]) && best_ba[j] == i)
      out.push_back({i, j});
  }
  return out;
}

}  // namespace

std::vector<std::pair<int, int>> MatchDescriptors(const SiftDescriptors& a_bytes, const SiftDescriptors& b_bytes,
                                                  double ratio, DescriptorProduct product) {
  const int na = static_cast<int>(a_bytes.rows()), nb = static_cast<int>(b_bytes.rows());
  if (na < 2 || nb < 2) return {};
  if (product == DescriptorProduct::kAuto)
    product = Int8DescriptorProductIsExact() ? DescriptorProduct::kInt8 : DescriptorProduct::kFloat;
  if (product == DescriptorProduct::kInt8) {
    if (!Int8DescriptorProductIsExact())
      throw std::logic_error("MatchDescriptors: oneDNN's int8 product is not exact here");
    // oneDNN multiplies u8 by s8 only: b stays u8 and a is stored as a - 128, so the product is
    // a.b - 128 sum(b), and the 128 sum(b) goes into b's norm term: |a|^2 + (|b|^2 - 256 sum(b)) - 2 (a - 128).b.
    // Every term is an exact integer (|a|^2 <= 128 x 255^2).
    const Eigen::Matrix<int8_t, Eigen::Dynamic, 128, Eigen::RowMajor> a_shifted =
        (a_bytes.cast<int>().array() - 128).cast<int8_t>();
    std::vector<int32_t> norms_a(na), norms_b(nb);
    for (int i = 0; i < na; ++i) norms_a[i] = a_bytes.row(i).cast<int32_t>().squaredNorm();
    for (int j = 0; j < nb; ++j)
      norms_b[j] = b_bytes.row(j).cast<int32_t>().squaredNorm() - 256 * b_bytes.row(j).cast<int32_t>().sum();
    // oneDNN runs its product on OpenMP threads; the pairs are already spread over the cores.
    const ScopedOmpThreads one_thread(1);
    return MutualRatioMatches<int32_t>(
        na, nb, norms_a, [&](int j) { return norms_b[j]; }, ratio,
        [&](int j0, int columns, int32_t* dot) {
          // Row-major dot (columns x na) = b[j0 .. j0 + columns) (a - 128)^T, i.e. column-major na x columns.
          const int32_t offset = 0;
          if (dnnl_gemm_u8s8s32('N', 'T', 'F', columns, na, 128, 1.f, b_bytes.row(j0).data(), 128, 0, a_shifted.data(),
                                128, 0, 0.f, dot, na, &offset) != dnnl_success) {
            throw std::runtime_error("MatchDescriptors: oneDNN's dnnl_gemm_u8s8s32 failed");
          }
        });
  }
  const Eigen::Matrix<float, Eigen::Dynamic, 128, Eigen::RowMajor> a = a_bytes.cast<float>(), b = b_bytes.cast<float>();
  const Eigen::VectorXf norms_a_vector = a.rowwise().squaredNorm(), norms_b = b.rowwise().squaredNorm();
  const std::vector<float> norms_a(norms_a_vector.data(), norms_a_vector.data() + na);
  // dot = a b^T through the BLAS (3x Eigen's product here). The products of 0..255 integers over
  // 128 terms are exact in float, so any blocking gives the same distances.
  return MutualRatioMatches<float>(
      na, nb, norms_a, [&](int j) { return norms_b(j); }, ratio,
      [&](int j0, int columns, float* dot) { DotProducts128(a.data(), na, b.row(j0).data(), columns, dot); });
}

namespace {

// Per camera group with pairs inside it, the focal length from the pairs' fundamental matrices
// (pixels, USAC MAGSAC++), written into every camera of the group where the estimate is distinct.
void EstimateGroupFocals(const std::vector<std::pair<int, int>>& pairs,
                         const std::vector<std::vector<std::pair<int, int>>>& pair_matches,
                         const std::vector<std::vector<cv::Point2d>>& pixels, const std::vector<int>& group,
                         const ViewGraphOptions& options, const std::vector<std::string>& names,
                         std::vector<Camera>* cameras) {
  const int num_pairs = static_cast<int>(pairs.size());
  std::vector<std::optional<Eigen::Matrix3d>> fundamentals(num_pairs);
  cv::parallel_for_(cv::Range(0, num_pairs), [&](const cv::Range& range) {
    for (int p = range.start; p < range.end; ++p) {
      const auto [i, j] = pairs[p];
      if (group[i] != group[j] || static_cast<int>(pair_matches[p].size()) < options.min_inliers) continue;
      std::vector<cv::Point2d> pi, pj;
      for (const auto& [a, b] : pair_matches[p]) pi.push_back(pixels[i][a]), pj.push_back(pixels[j][b]);
      cv::Mat mask;
      const cv::Mat f =
          cv::findFundamentalMat(pi, pj, cv::USAC_MAGSAC, options.ransac_threshold_px, options.ransac_confidence, mask);
      if (f.rows != 3 || f.cols != 3 || cv::countNonZero(mask) < options.min_inliers) continue;
      Eigen::Matrix3d e;
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) e(a, b) = f.at<double>(a, b);
      fundamentals[p] = e / e.norm();
    }
  });
  std::vector<int> group_ids(group.begin(), group.end());
  std::sort(group_ids.begin(), group_ids.end());
  group_ids.erase(std::unique(group_ids.begin(), group_ids.end()), group_ids.end());
  for (int g : group_ids) {
    std::vector<Eigen::Matrix3d> f;
    for (int p = 0; p < num_pairs; ++p)
      if (fundamentals[p] && group[pairs[p].first] == g) f.push_back(*fundamentals[p]);
    const int first = static_cast<int>(std::find(group.begin(), group.end(), g) - group.begin());
    const Camera& c = (*cameras)[first];
    const FocalEstimate e = EstimateFocalFromFundamentals(f, c.width, c.height, options.focal_estimation);
    if (!e.distinct) {
      LOG_INFO(
          "{} and its camera group: focal length not determined by {} fundamental matrices; the prior {:.1f} px "
          "stays (bundle adjustment refines it)",
          names[first], e.num_pairs, c.fx);
      continue;
    }
    LOG_INFO("{} and its camera group: focal length {:.1f} px from {} fundamental matrices (prior {:.1f} px)",
             names[first], e.focal_px, e.num_pairs, c.fx);
    for (size_t k = 0; k < group.size(); ++k)
      if (group[k] == g) {
        Camera& ck = (*cameras)[k];
        ck.fy *= e.focal_px / ck.fx;
        ck.fx = e.focal_px;
      }
  }
}

}  // namespace

std::optional<ViewGraphEdge> EstimateTwoViewGeometry(const std::vector<Eigen::Vector2d>& keypoints_i,
                                                     const std::vector<Eigen::Vector2d>& keypoints_j,
                                                     const std::vector<std::pair<int, int>>& matches, double focal_px,
                                                     const ViewGraphOptions& options) {
  if (static_cast<int>(matches.size()) < options.min_inliers) return std::nullopt;
  std::vector<cv::Point2d> pi, pj;
  pi.reserve(matches.size());
  pj.reserve(matches.size());
  for (const auto& [a, b] : matches) {
    pi.push_back({keypoints_i[a].x(), keypoints_i[a].y()});
    pj.push_back({keypoints_j[b].x(), keypoints_j[b].y()});
  }
  // Normalised coordinates: the pixel threshold becomes threshold / focal.
  const double threshold = options.ransac_threshold_px / focal_px;
  const bool usac = options.estimator == TwoViewEstimator::kUsac;
  const int method = usac ? cv::USAC_MAGSAC : cv::RANSAC;
  const int num_matches = static_cast<int>(matches.size());
  const int e_iterations =
      options.early_rejection
          ? RansacIterationCap(num_matches, options.min_inliers, 5, options.ransac_confidence, kMaxEssentialIterations)
          : kMaxEssentialIterations;
  const cv::Mat identity_k = cv::Mat::eye(3, 3, CV_64F);
  cv::Mat mask;
  int inliers = 0;
  Eigen::Matrix3d rot = Eigen::Matrix3d::Identity();
  Eigen::Vector3d trans = Eigen::Vector3d::Zero();
  cv::Mat e;
  if (usac) {
    // cv::USAC_MAGSAC's settings (OpenCV's usac setParameters), with the iteration cap, which the
    // flag-only overload ignores for essential matrices.
    cv::UsacParams params;
    params.confidence = options.ransac_confidence;
    params.isParallel = false;
    params.loIterations = 10;
    params.loMethod = cv::LOCAL_OPTIM_SIGMA;
    params.loSampleSize = 50;
    params.maxIterations = e_iterations;
    params.randomGeneratorState = static_cast<int>(options.seed);
    params.sampler = cv::SAMPLING_UNIFORM;
    params.score = cv::SCORE_METHOD_MAGSAC;
    params.threshold = threshold;
    e = cv::findEssentialMat(pi, pj, identity_k, identity_k, cv::noArray(), cv::noArray(), mask, params);
  } else {
    e = cv::findEssentialMat(pi, pj, identity_k, cv::RANSAC, options.ransac_confidence, threshold, e_iterations, mask);
  }
  const bool e_valid = e.rows == 3 && e.cols == 3;                     // else degenerate, or several solutions stacked
  const int estimator_inliers = e_valid ? cv::countNonZero(mask) : 0;  // before the test in front
  // Early rejection: a homography's inliers fit the essential matrix [t]x R of its rotation for
  // any t, so too few essential-matrix inliers leave no edge either way.
  if (options.early_rejection && (!e_valid || estimator_inliers < options.min_inliers)) return std::nullopt;
  if (e_valid) {
    std::vector<Eigen::Vector2d> all_i(num_matches), all_j(num_matches);
    for (int m = 0; m < num_matches; ++m) all_i[m] = {pi[m].x, pi[m].y}, all_j[m] = {pj[m].x, pj[m].y};
    std::vector<uint8_t> in_front(num_matches, 1);  // cv::recoverPose takes no mask as all matches
    if (static_cast<int>(mask.total()) == num_matches) mask.reshape(1, 1).copyTo(in_front);
    Eigen::Matrix3d e_eigen;
    cv::cv2eigen(e, e_eigen);
    inliers = RecoverPoseFromEssential(e_eigen, all_i, all_j, &in_front, &rot, &trans);
    if (usac || options.refine_ransac)
      inliers = RefineOnInliers(all_i, all_j, threshold, inliers, &rot, &trans, &in_front);
    mask = cv::Mat(in_front, true);
  }
  // A homography on the same matches that explains them about as well (COLMAP's ratio 0.8) is
  // a planar scene or photos from one spot. Seen from one spot (the rays agree once the
  // homography's rotation is taken out), the essential matrix is degenerate: the rotation comes
  // from the homography and the edge has no translation direction.
  // Only a homography with more than kPlanarInlierRatio of the essential matrix's inliers (and
  // min_inliers) changes the edge: with early rejection, the hypotheses are capped for that count.
  // It is not estimated where the essential matrix rules a pure rotation out (PanoramicRuledOut):
  // 90 % of forward-facing pairs, geometry 14.4 -> 11.1 s on 96 such views.
  int h_inliers = 0;
  bool panoramic = false;
  bool planar = false;
  bool h_fitted = false;
  cv::Mat planar_h;  // the homography fitted here, where it makes the pair planar
  if (!(e_valid && inliers >= options.min_inliers && PanoramicRuledOut(pi, pj, mask, rot, trans))) {
    // The homography fitted with hypotheses capped for h_needed inliers: its inlier mask, count,
    // and rotation's median parallax (infinite where it cannot make the pair panoramic).
    struct Fit {
      cv::Mat h;
      cv::Mat h_mask;
      int h_inliers = 0;
      Eigen::Matrix3d r_h = Eigen::Matrix3d::Identity();
      double parallax_deg = std::numeric_limits<double>::infinity();
    };
    const auto fit_homography = [&](int h_needed) {
      const int h_iterations =
          options.early_rejection
              ? RansacIterationCap(num_matches, h_needed, 4, options.ransac_confidence, kMaxEarlyHomographyIterations)
              : kMaxHomographyIterations;
      Fit f;
      f.h = cv::findHomography(pi, pj, method, threshold, f.h_mask, h_iterations, options.ransac_confidence);
      const cv::Mat& h = f.h;
      f.h_inliers = h.empty() ? 0 : cv::countNonZero(f.h_mask);
      if (f.h_inliers >= options.min_inliers && f.h_inliers > kPlanarInlierRatio * inliers) {
        Eigen::Matrix3d hm;
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b) hm(a, b) = h.at<double>(a, b);
        const Eigen::JacobiSVD<Eigen::Matrix3d> svd(hm, Eigen::ComputeFullU | Eigen::ComputeFullV);
        f.r_h = svd.matrixU() * svd.matrixV().transpose();
        if (f.r_h.determinant() < 0) f.r_h = -f.r_h;
        f.parallax_deg = MedianParallaxDeg(pi, pj, f.h_mask, f.r_h);
      }
      return f;
    };
    const int h_needed = std::max(options.min_inliers, static_cast<int>(kPlanarInlierRatio * inliers) + 1);
    const int estimator_needed = static_cast<int>(kPlanarInlierRatio * estimator_inliers) + 1;
    Fit fit;
    if (options.early_rejection && estimator_needed > h_needed) {
      // Too few inliers in front (short baselines: nearly every point beyond 50 baselines): a
      // homography capped for min_inliers takes all 2000 hypotheses (~48 ms a pair, 46 % of the
      // geometry on 192 forward-facing views). First one capped for the essential matrix's own
      // count, which a panoramic pair's homography reaches; only where its rotation leaves the rays
      // within kFarRefitDeg is it fitted again, up to kMaxEarlyHomographyIterations hypotheses.
      // On those 192 views: 76 -> 62 s, 10 of 2560 edges (panoramic ones) fewer, median rotation
      // error 0.0987 -> 0.0990 deg (with 2000 hypotheses for the refit).
      fit = fit_homography(estimator_needed);
      if (fit.parallax_deg < kFarRefitDeg) fit = fit_homography(h_needed);
    } else {
      fit = fit_homography(h_needed);
    }
    h_inliers = fit.h_inliers;
    h_fitted = true;
    if (fit.h_inliers > kPlanarInlierRatio * inliers) planar_h = fit.h;
    if (fit.parallax_deg < kPanoramicParallaxDeg) {
      panoramic = true;
      rot = fit.r_h;
      trans.setZero();
      mask = fit.h_mask;
      inliers = fit.h_inliers;
    }
  }
  // Planar: a homography explains more than kPlanarInlierRatio of the essential matrix's inliers
  // but the pair is not panoramic. Matches on one plane fit a one-parameter family of essential
  // matrices equally well, so the estimate (refined or not) may be any member: on ViSP's cube (a
  // poster with a small cube on it) 35-45 % of the edges were 2-38 deg off, consistently enough
  // that rotation averaging settled on cameras 7 deg off in some seeds, with nothing flagged. The
  // homography's own decomposition is the pose (COLMAP's PLANAR_OR_PANORAMIC configuration) where
  // it explains at least as many matches as the essential matrix's pose; where the essential
  // matrix explains more, points off the plane determine it.
  if (!panoramic && e_valid && inliers >= options.min_inliers) {
    cv::Mat h = planar_h;
    if (!h_fitted) {
      // Fitted among the essential matrix's inliers only, where a planar pair's homography holds
      // more than 80 % of them: a few dozen hypotheses (over all matches, pairs with many outliers
      // took up to 2000: geometry 2.4 -> 3.3 s on 96 forward-facing views).
      std::vector<cv::Point2d> qi, qj;
      for (int m = 0; m < num_matches; ++m)
        if (mask.at<uint8_t>(m) != 0) qi.push_back(pi[m]), qj.push_back(pj[m]);
      const int h_needed = static_cast<int>(kPlanarInlierRatio * inliers) + 1;
      const int h_iterations = RansacIterationCap(static_cast<int>(qi.size()), h_needed, 4, options.ransac_confidence,
                                                  kMaxHomographyIterations);
      cv::Mat h_mask;
      h = cv::findHomography(qi, qj, cv::RANSAC, threshold, h_mask, h_iterations, options.ransac_confidence);
      if (!h.empty()) h_inliers = cv::countNonZero(h_mask);
    }
    if (!h.empty() && h_inliers > kPlanarInlierRatio * inliers) {
      std::vector<Eigen::Vector2d> all_i(num_matches), all_j(num_matches);
      for (int m = 0; m < num_matches; ++m) all_i[m] = {pi[m].x, pi[m].y}, all_j[m] = {pj[m].x, pj[m].y};
      Eigen::Matrix3d rot_h = Eigen::Matrix3d::Identity();
      Eigen::Vector3d trans_h = Eigen::Vector3d::Zero();
      std::vector<uint8_t> mask_h;
      int inliers_h = PoseFromHomography(h, all_i, all_j, threshold, &rot_h, &trans_h, &mask_h);
      // Refined as the essential matrix's pose is, where that gains more than noise would: points
      // off the plane sharpen it (unrefined, the procedural 20-view sets of
      // bench/dbarf_poses_bench.sh were 10-75 % worse), but on a plane alone the refinement only
      // slides along the family (the rendered plane of view_graph_test.cc: 0.12 -> 0.40 deg).
      if (inliers_h >= 5) {
        std::vector<Eigen::Vector2d> xi, xj;
        for (int m = 0; m < num_matches; ++m)
          if (mask_h[m] != 0) xi.push_back(all_i[m]), xj.push_back(all_j[m]);
        Eigen::Matrix3d rot_r = rot_h;
        Eigen::Vector3d trans_r = trans_h;
        std::vector<uint8_t> mask_r = mask_h;
        const int inliers_r = RefineOnInliers(all_i, all_j, threshold, inliers_h, &rot_r, &trans_r, &mask_r);
        if (RelativePoseCost(xi, xj, threshold, rot_h, trans_h) - RelativePoseCost(xi, xj, threshold, rot_r, trans_r) >
            kRefinementNoiseGain) {
          rot_h = rot_r, trans_h = trans_r, mask_h = std::move(mask_r), inliers_h = inliers_r;
        }
      }
      if (inliers_h >= inliers) {
        rot = rot_h, trans = trans_h, inliers = inliers_h, mask = cv::Mat(mask_h, true);
        planar = true;
      }
    }
  }
  if (inliers < options.min_inliers) return std::nullopt;
  ViewGraphEdge edge;
  edge.num_matches = static_cast<int>(matches.size());
  edge.num_inliers = inliers;
  edge.num_homography_inliers = h_inliers;
  edge.panoramic = panoramic;
  edge.planar = planar;
  edge.j_from_i = Rigid3d(rot, panoramic ? Eigen::Vector3d::Zero() : Eigen::Vector3d(trans.normalized()));
  for (size_t m = 0; m < matches.size(); ++m)
    if (mask.at<uint8_t>(static_cast<int>(m)) != 0) edge.inlier_matches.push_back(matches[m]);
  return edge;
}

namespace {

template <typename ImageT>
SiftFeatures ExtractSift(const ImageT& image, const ViewGraphOptions& options) {
  const int up = EffectiveUpsample(options, std::max(image.width, image.height));
  cv::Mat gray = ToGray8(image);
  if (up > 1) cv::resize(gray, gray, cv::Size(), up, up, cv::INTER_LINEAR);
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat desc;
  const double sparse = options.sparse_contrast_threshold;
  const bool has_sparse = sparse > 0 && sparse < options.contrast_threshold;
  // A small image (one enlarged) goes straight to the sparse threshold: it has few pixels to give
  // keypoints from.
  cv::SIFT::create(options.max_features, 3, has_sparse && up > 1 ? sparse : options.contrast_threshold)
      ->detectAndCompute(gray, cv::noArray(), keypoints, desc);
  if (has_sparse && up == 1 &&
      static_cast<int>(keypoints.size()) < std::min(options.sparse_image_keypoints, options.max_features)) {
    keypoints.clear();
    cv::SIFT::create(options.max_features, 3, sparse)->detectAndCompute(gray, cv::noArray(), keypoints, desc);
  }
  SiftFeatures out;
  out.descriptors.resize(desc.rows, 128);
  const bool root = options.normalization == SiftNormalization::kL1Root;
  for (int r = 0; r < desc.rows && desc.cols == 128; ++r) {
    // OpenCV's descriptor is 512x a unit vector; RootSIFT's bytes are 512x the square roots of its
    // unit-L1 version (COLMAP's FeatureDescriptorsToUnsignedByte scales and clamps alike).
    const float* d = desc.ptr<float>(r);
    float l1 = 0;
    if (root)
      for (int c = 0; c < 128; ++c) l1 += std::abs(d[c]);
    for (int c = 0; c < 128; ++c) {
      const float v = root && l1 > 0 ? 512.f * std::sqrt(std::abs(d[c]) / l1) : d[c];
      out.descriptors(r, c) = static_cast<uint8_t>(std::clamp(v, 0.f, 255.f) + 0.5f);
    }
  }
  // OpenCV puts pixel centres at integer coordinates, nerfreg at +0.5; an image enlarged by `up`
  // (pixel-area aligned, as cv::resize is) maps x_up + 0.5 = up * (x + 0.5).
  for (const auto& kp : keypoints) out.keypoints.emplace_back((kp.pt.x + 0.5) / up, (kp.pt.y + 0.5) / up);
  return out;
}

template <typename ImageT>
void CheckSizes(const std::vector<ImageT>& images, const std::vector<Camera>& cameras,
                const std::vector<std::string>& names, bool equal_sizes) {
  for (size_t k = 0; k < images.size(); ++k) {
    if (equal_sizes && (images[k].width != images[0].width || images[k].height != images[0].height)) {
      ThrowInputError(names[k], "size",
                      std::to_string(images[0].width) + "x" + std::to_string(images[0].height) + " like " + names[0] +
                          ", got " + std::to_string(images[k].width) + "x" + std::to_string(images[k].height));
    }
    if (images[k].width != cameras[k].width || images[k].height != cameras[k].height) {
      ThrowInputError(names[k], "size",
                      "the camera's " + std::to_string(cameras[k].width) + "x" + std::to_string(cameras[k].height));
    }
  }
}

template <typename ImageT>
ViewGraph BuildGraph(const std::vector<ImageT>& images, const std::vector<Camera>& cameras,
                     const std::vector<std::string>& names, const ViewGraphOptions& options, StageTimes* times,
                     const std::vector<int>& camera_group, const std::vector<std::pair<int, int>>& pairs_in) {
  options.Check();
  if (images.size() != cameras.size() || images.size() != names.size() ||
      (!camera_group.empty() && camera_group.size() != images.size())) {
    throw std::invalid_argument("BuildViewGraph: images, cameras, names and groups differ in count");
  }
  CheckImageSizes(images, cameras, names, /*equal_sizes=*/false);
  ViewGraph graph;
  graph.names = names;
  graph.cameras = cameras;
  const int n = static_cast<int>(images.size());
  std::vector<SiftFeatures> features(n);
  const Timer timer;
  // Images, then pairs, in parallel (OpenCV's pool: all cores, or cv::setNumThreads). Each item
  // writes only its own slot, so the graph is the same whatever the thread count.
  cv::parallel_for_(cv::Range(0, n), [&](const cv::Range& range) {
    for (int k = range.start; k < range.end; ++k) features[k] = ExtractSiftFeatures(images[k], options);
  });
  std::vector<std::vector<cv::Point2d>> pixels(n);
  graph.keypoints.resize(n);
  for (int k = 0; k < n; ++k) {
    graph.keypoints[k] = features[k].keypoints;
    for (const auto& uv : features[k].keypoints) pixels[k].push_back({uv.x(), uv.y()});
  }
  const double seconds_features = timer.Seconds();
  std::vector<std::pair<int, int>> pairs = pairs_in;
  if (pairs.empty()) {
    std::vector<SiftDescriptors> descriptors(n);
    for (int k = 0; k < n; ++k) descriptors[k] = features[k].descriptors;
    pairs = SelectPairs(descriptors, names, options.pairs);
  }
  const int num_pairs = static_cast<int>(pairs.size());
  std::vector<std::vector<std::pair<int, int>>> pair_matches(num_pairs);
  cv::parallel_for_(cv::Range(0, num_pairs), [&](const cv::Range& range) {
    for (int p = range.start; p < range.end; ++p)
      pair_matches[p] =
          MatchDescriptors(features[pairs[p].first].descriptors, features[pairs[p].second].descriptors, options.ratio);
  });
  const double seconds_matching = timer.Seconds() - seconds_features;
  if (options.estimate_focal) {
    std::vector<int> group = camera_group;
    if (group.empty())
      for (int k = 0; k < n; ++k) group.push_back(images[k].width * 100003 + images[k].height);
    EstimateGroupFocals(pairs, pair_matches, pixels, group, options, names, &graph.cameras);
  }
  const double seconds_focal = timer.Seconds() - seconds_features - seconds_matching;
  std::vector<std::vector<Eigen::Vector2d>> normalised(n);
  for (int k = 0; k < n; ++k)
    for (const auto& uv : graph.keypoints[k]) normalised[k].push_back(graph.cameras[k].CamFromImg(uv).head<2>());
  std::vector<std::optional<ViewGraphEdge>> pair_edges(num_pairs);
  cv::parallel_for_(cv::Range(0, num_pairs), [&](const cv::Range& range) {
    for (int p = range.start; p < range.end; ++p) {
      const auto [i, j] = pairs[p];
      const double f = 0.25 * (graph.cameras[i].fx + graph.cameras[i].fy + graph.cameras[j].fx + graph.cameras[j].fy);
      pair_edges[p] = EstimateTwoViewGeometry(normalised[i], normalised[j], pair_matches[p], f, options);
      if (pair_edges[p]) pair_edges[p]->i = i, pair_edges[p]->j = j;
    }
  });
  for (auto& edge : pair_edges)
    if (edge) graph.edges.push_back(std::move(*edge));
  if (times != nullptr) {
    times->Record("features", seconds_features);
    times->Record("matching", seconds_matching);
    if (options.estimate_focal) times->Record("focal estimation", seconds_focal);
    times->Record("geometry", timer.Seconds() - seconds_features - seconds_matching - seconds_focal);
  }
  for (int k : graph.Isolated()) LOG_WARN("{}: no geometric matches to any other image; left out", names[k]);
  return graph;
}

}  // namespace

SiftFeatures ExtractSiftFeatures(const Image& image, const ViewGraphOptions& options) {
  return ExtractSift(image, options);
}

SiftFeatures ExtractSiftFeatures(const PackedImage& image, const ViewGraphOptions& options) {
  return ExtractSift(image, options);
}

void CheckImageSizes(const std::vector<Image>& images, const std::vector<Camera>& cameras,
                     const std::vector<std::string>& names, bool equal_sizes) {
  CheckSizes(images, cameras, names, equal_sizes);
}

void CheckImageSizes(const std::vector<PackedImage>& images, const std::vector<Camera>& cameras,
                     const std::vector<std::string>& names, bool equal_sizes) {
  CheckSizes(images, cameras, names, equal_sizes);
}

ViewGraph BuildViewGraph(const std::vector<Image>& images, const std::vector<Camera>& cameras,
                         const std::vector<std::string>& names, const ViewGraphOptions& options, StageTimes* times,
                         const std::vector<int>& camera_group, const std::vector<std::pair<int, int>>& pairs) {
  return BuildGraph(images, cameras, names, options, times, camera_group, pairs);
}

ViewGraph BuildViewGraph(const std::vector<PackedImage>& images, const std::vector<Camera>& cameras,
                         const std::vector<std::string>& names, const ViewGraphOptions& options, StageTimes* times,
                         const std::vector<int>& camera_group, const std::vector<std::pair<int, int>>& pairs) {
  return BuildGraph(images, cameras, names, options, times, camera_group, pairs);
}

}  // namespace nerfreg
