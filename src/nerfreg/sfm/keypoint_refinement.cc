#include "nerfreg/sfm/keypoint_refinement.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <optional>
#include <stdexcept>
#include <thread>
#include <utility>

#include <Eigen/Dense>

#include "nerfreg/viewgraph/view_graph.h"

namespace nerfreg {

void KeypointRefinementOptions::Check() const {
  if (window_px < 5 || window_px % 2 == 0) throw std::invalid_argument("KeypointRefinementOptions: window_px");
  if (!(max_shift_px > 0)) throw std::invalid_argument("KeypointRefinementOptions: max_shift_px <= 0");
  if (max_iterations < 1) throw std::invalid_argument("KeypointRefinementOptions: max_iterations < 1");
  if (!(epsilon_px > 0)) throw std::invalid_argument("KeypointRefinementOptions: epsilon_px <= 0");
  if (!(max_distortion >= 0)) throw std::invalid_argument("KeypointRefinementOptions: max_distortion < 0");
  if (!(min_correlation <= 1)) throw std::invalid_argument("KeypointRefinementOptions: min_correlation > 1");
  if (num_threads < 1) throw std::invalid_argument("KeypointRefinementOptions: num_threads < 1");
}

namespace {

// The grey levels SIFT saw (FeatureGrey), row-major, with bilinear sampling at coordinates whose
// integers are pixel centres. Held as 16-bit levels: every image of the run has one at once, and
// at float they were the largest allocation of a 500-photo run after the photos themselves
// (1.5 GB at 1008 x 756; issue 44); 1 / 65535 is far below an 8-bit photo's own step.
struct Grey {
  int width = 0, height = 0;
  std::vector<std::uint16_t> v;  // [height * width], grey * 65535

  template <typename ImageT>  // Image or PackedImage
  explicit Grey(const ImageT& im) : width(im.width), height(im.height), v(static_cast<size_t>(im.width) * im.height) {
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) {
        const float g = FeatureGrey(im, x, y);  // clamped to [0, 1], NaN to 0
        v[static_cast<size_t>(y) * width + x] =
            static_cast<std::uint16_t>((g > 0.f ? (g < 1.f ? g : 1.f) : 0.f) * 65535.f + 0.5f);
      }
  }
  bool Inside(double x, double y) const { return x >= 0 && y >= 0 && x <= width - 1.001 && y <= height - 1.001; }
  // Requires Inside(x, y).
  float At(double x, double y) const {
    const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
    const float fx = static_cast<float>(x - x0), fy = static_cast<float>(y - y0);
    const std::uint16_t* p = &v[static_cast<size_t>(y0) * width + x0];
    const float top = (1 - fx) * p[0] + fx * p[1], bottom = (1 - fx) * p[width] + fx * p[width + 1];
    return ((1 - fy) * top + fy * bottom) * (1.f / 65535.f);
  }
};

// The position in `image` of the point at `from` in `tmpl`: the affine warp of the window around
// `from` that best matches `image` near `to` (the start), by inverse-compositional Gauss-Newton
// (Baker and Matthews 2004) on grey levels with the warped patch's mean and contrast matched to
// the template's (as ECC's zero-mean normalisation). The affine part absorbs the change of scale,
// rotation and shear between the views, which biases a translation-only alignment (tried first:
// it moved the real cube's poses 0.06 deg away from both COLMAPs). nullopt where the window
// leaves an image, the warp degenerates, or the result moves further or correlates less than the
// options allow.
std::optional<Eigen::Vector2d> AlignAffine(const Grey& tmpl, const Eigen::Vector2d& from, const Grey& image,
                                           const Eigen::Vector2d& to, const KeypointRefinementOptions& options) {
  const int r = options.window_px / 2, side = options.window_px, count = side * side;
  if (!tmpl.Inside(from.x() - r - 1, from.y() - r - 1) || !tmpl.Inside(from.x() + r + 1, from.y() + r + 1))
    return std::nullopt;
  // Template, its gradients and the steepest-descent images (d warp / d p at the identity, p =
  // (a11 - 1, a12, a21, a22 - 1, tx, ty)).
  Eigen::VectorXf t(count);
  Eigen::Matrix<float, Eigen::Dynamic, 6> sd(count, 6);
  int k = 0;
  for (int v = -r; v <= r; ++v)
    for (int u = -r; u <= r; ++u, ++k) {
      const double x = from.x() + u, y = from.y() + v;
      t(k) = tmpl.At(x, y);
      const float gx = 0.5f * (tmpl.At(x + 1, y) - tmpl.At(x - 1, y));
      const float gy = 0.5f * (tmpl.At(x, y + 1) - tmpl.At(x, y - 1));
      sd.row(k) << gx * u, gx * v, gy * u, gy * v, gx, gy;
    }
  const float t_mean = t.mean();
  t.array() -= t_mean;
  const float t_norm = t.norm();
  if (t_norm < 1e-6f) return std::nullopt;
  const Eigen::Matrix<double, 6, 6> h = (sd.transpose() * sd).cast<double>();
  const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> solver(h);
  if (solver.info() != Eigen::Success || !(h.diagonal().minCoeff() > 0)) return std::nullopt;
  Eigen::Matrix3d warp = Eigen::Matrix3d::Identity();  // template offset (u, v, 1) -> image offset from `to`
  Eigen::VectorXf w(count);
  for (int it = 0; it < options.max_iterations; ++it) {
    k = 0;
    for (int v = -r; v <= r; ++v)
      for (int u = -r; u <= r; ++u, ++k) {
        const Eigen::Vector3d q = warp * Eigen::Vector3d(u, v, 1);
        const double x = to.x() + q.x(), y = to.y() + q.y();
        if (!image.Inside(x, y)) return std::nullopt;
        w(k) = image.At(x, y);
      }
    w.array() -= w.mean();
    const float w_norm = w.norm();
    if (w_norm < 1e-6f) return std::nullopt;
    const Eigen::VectorXf e = w * (t_norm / w_norm) - t;
    const Eigen::Matrix<double, 6, 1> dp = solver.solve((sd.transpose() * e).cast<double>());
    Eigen::Matrix3d step;
    step << 1 + dp(0), dp(1), dp(4), dp(2), 1 + dp(3), dp(5), 0, 0, 1;
    warp = warp * step.inverse();
    if (std::hypot(dp(4), dp(5)) < options.epsilon_px) break;
  }
  const Eigen::Matrix2d linear = warp.topLeftCorner<2, 2>();
  const Eigen::Vector2d shift = warp.topRightCorner<2, 1>();
  if (!shift.allFinite() || shift.norm() > options.max_shift_px ||
      (linear - Eigen::Matrix2d::Identity()).cwiseAbs().maxCoeff() > options.max_distortion)
    return std::nullopt;
  if (options.min_correlation > -1) {
    // Zero-mean normalised correlation at the final warp.
    k = 0;
    for (int v = -r; v <= r; ++v)
      for (int u = -r; u <= r; ++u, ++k) {
        const Eigen::Vector3d q = warp * Eigen::Vector3d(u, v, 1);
        if (!image.Inside(to.x() + q.x(), to.y() + q.y())) return std::nullopt;
        w(k) = image.At(to.x() + q.x(), to.y() + q.y());
      }
    w.array() -= w.mean();
    const float c = w.dot(t) / std::max(1e-12f, w.norm() * t_norm);
    if (c < options.min_correlation) return std::nullopt;
  }
  return to + shift;
}

template <typename ImageT>
KeypointRefinementSummary RefineKeypoints(const std::vector<ImageT>& images, const ViewGraph& graph,
                                          const std::vector<Track>& tracks, const KeypointRefinementOptions& options,
                                          std::vector<std::vector<Eigen::Vector2d>>* keypoints) {
  options.Check();
  const int n = static_cast<int>(keypoints->size());
  if (static_cast<int>(images.size()) != n)
    throw std::invalid_argument("RefineTrackKeypoints: one image per keypoint list");
  std::map<std::pair<int, int>, int> inliers;  // (lower image, higher image) -> the edge's inliers
  for (const ViewGraphEdge& e : graph.edges) inliers[{std::min(e.i, e.j), std::max(e.i, e.j)}] = e.num_inliers;
  const auto edge_inliers = [&](int i, int j) {
    const auto it = inliers.find({std::min(i, j), std::max(i, j)});
    return it == inliers.end() ? 0 : it->second;
  };
  // Each track as a tree over its images' edges, strongest first (Prim's maximum spanning tree from
  // the element with the strongest edges): each observation is aligned with its parent, the most
  // alike view, already aligned itself, as KLT follows a point along a sequence.
  struct Link {
    int parent_image, parent_keypoint, image, keypoint;
  };
  std::vector<std::vector<Link>> levels;  // levels[d]: the links d + 1 steps from their root
  KeypointRefinementSummary summary;
  for (const Track& track : tracks) {
    const int m = static_cast<int>(track.elements.size());
    if (m < 2) continue;
    ++summary.num_tracks;
    Eigen::MatrixXi weight = Eigen::MatrixXi::Zero(m, m);  // [m, m]
    for (int a = 0; a < m; ++a)
      for (int b = a + 1; b < m; ++b)
        weight(a, b) = weight(b, a) = edge_inliers(track.elements[a].image, track.elements[b].image);
    int root = 0;
    for (int a = 1; a < m; ++a)
      if (weight.row(a).sum() > weight.row(root).sum()) root = a;
    std::vector<int> depth(m, -1);
    depth[root] = 0;
    for (int added = 1; added < m; ++added) {
      int best_a = -1, best_b = -1, best = 0;
      for (int a = 0; a < m; ++a) {
        if (depth[a] < 0) continue;
        for (int b = 0; b < m; ++b)
          if (depth[b] < 0 && weight(a, b) > best) best = weight(a, b), best_a = a, best_b = b;
      }
      if (best_b < 0) break;  // the rest shares no edge with the tree
      depth[best_b] = depth[best_a] + 1;
      if (static_cast<int>(levels.size()) < depth[best_b]) levels.resize(depth[best_b]);
      const TrackElement& pe = track.elements[best_a];
      const TrackElement& ce = track.elements[best_b];
      levels[depth[best_b] - 1].push_back({pe.image, pe.keypoint, ce.image, ce.keypoint});
    }
  }
  std::vector<std::optional<Grey>> grey(n);
  for (const auto& level : levels)
    for (const Link& l : level)
      for (int k : {l.parent_image, l.image})
        if (!grey[k]) grey[k].emplace(images[k]);
  // Level by level: the parents have moved before their children are aligned with them; within a
  // level the links are independent (each moves its own keypoint), split over the threads. Grey's
  // pixel centres are at integers, the keypoints' at +0.5.
  const Eigen::Vector2d half(0.5, 0.5);
  const int num_threads = std::max(1, std::min<int>(options.num_threads, std::thread::hardware_concurrency()));
  std::vector<double> shifts;
  for (const auto& level : levels) {
    std::vector<double> shift(level.size(), -1);  // per link; -1: refused
    const auto align = [&](size_t begin, size_t end) {
      for (size_t k = begin; k < end; ++k) {
        const Link& l = level[k];
        const Eigen::Vector2d from = (*keypoints)[l.parent_image][l.parent_keypoint] - half;
        const Eigen::Vector2d to = (*keypoints)[l.image][l.keypoint] - half;
        const std::optional<Eigen::Vector2d> moved =
            AlignAffine(*grey[l.parent_image], from, *grey[l.image], to, options);
        if (!moved) continue;
        shift[k] = (*moved - to).norm();
        (*keypoints)[l.image][l.keypoint] = *moved + half;
      }
    };
    std::vector<std::thread> workers;
    const size_t chunk = (level.size() + num_threads - 1) / num_threads;
    for (int t = 1; t < num_threads && t * chunk < level.size(); ++t)
      workers.emplace_back(align, t * chunk, std::min(level.size(), (t + 1) * chunk));
    align(0, std::min(level.size(), chunk));
    for (std::thread& w : workers) w.join();
    for (double s : shift) {
      if (s < 0)
        ++summary.num_refused;
      else
        shifts.push_back(s);
    }
  }
  summary.num_moved = static_cast<int>(shifts.size());
  if (!shifts.empty()) {
    std::nth_element(shifts.begin(), shifts.begin() + shifts.size() / 2, shifts.end());
    summary.median_shift_px = shifts[shifts.size() / 2];
  }
  return summary;
}

}  // namespace

KeypointRefinementSummary RefineTrackKeypoints(const std::vector<Image>& images, const ViewGraph& graph,
                                               const std::vector<Track>& tracks,
                                               const KeypointRefinementOptions& options,
                                               std::vector<std::vector<Eigen::Vector2d>>* keypoints) {
  return RefineKeypoints(images, graph, tracks, options, keypoints);
}

KeypointRefinementSummary RefineTrackKeypoints(const std::vector<PackedImage>& images, const ViewGraph& graph,
                                               const std::vector<Track>& tracks,
                                               const KeypointRefinementOptions& options,
                                               std::vector<std::vector<Eigen::Vector2d>>* keypoints) {
  return RefineKeypoints(images, graph, tracks, options, keypoints);
}

}  // namespace nerfreg
