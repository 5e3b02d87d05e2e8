#include "nerfreg/viewgraph/view_graph.h"

#include <algorithm>
#include <cmath>
#include <Eigen/Core>
#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <stdexcept>

#include "nerfreg/util/error.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/timer.h"

namespace nerfreg {

int EffectiveUpsample(const ViewGraphOptions& options, int max_side) {
  if (options.upsample <= 1 || options.upsample_max_side <= 0) return options.upsample;
  return max_side > 0 && max_side * options.upsample <= options.upsample_max_side ? options.upsample : 1;
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
  if (upsample < 1 || upsample > 4) ThrowInputError("--sift-upsample", "", "1..4, got " + std::to_string(upsample));
  if (upsample_max_side < 0)
    ThrowInputError("--sift-upsample-max-side", "", ">= 0, got " + std::to_string(upsample_max_side));
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

cv::Mat ToGray8(const Image& im) {
  cv::Mat gray(im.height, im.width, CV_8UC1);
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x) {
      float v = 0;
      if (im.channels >= 3) {
        v = 0.299f * im.at(x, y, 0) + 0.587f * im.at(x, y, 1) + 0.114f * im.at(x, y, 2);
        if (im.channels == 4) v = v * im.at(x, y, 3) + (1 - im.at(x, y, 3));  // over white
      } else {
        v = im.at(x, y, 0);
      }
      gray.at<uint8_t>(y, x) = static_cast<uint8_t>(std::clamp(v, 0.f, 1.f) * 255.f + 0.5f);
    }
  return gray;
}

struct Features {
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> eigen;  // descriptors, one per row
  Eigen::VectorXf norms;                                                        // squared row norms
};

// Mutual nearest neighbours passing the ratio test in both directions, from one matrix of
// descriptor dot products (one GEMM instead of two brute-force passes):
// |a - b|^2 = |a|^2 + |b|^2 - 2 a.b.
std::vector<cv::DMatch> MatchMutualRatio(const Features& a, const Features& b, double ratio) {
  const int na = static_cast<int>(a.eigen.rows()), nb = static_cast<int>(b.eigen.rows());
  if (na < 2 || nb < 2) return {};
  const Eigen::MatrixXf dot = a.eigen * b.eigen.transpose();
  const float r2 = static_cast<float>(ratio * ratio);
  std::vector<int> best_ab(na, -1), best_ba(nb, -1);
  std::vector<float> d1b(nb, INFINITY), d2b(nb, INFINITY);
  std::vector<int> i1b(nb, -1);
  std::vector<float> d1a(na), distance(na);
  for (int i = 0; i < na; ++i) {
    float d1 = INFINITY, d2 = INFINITY;
    int j1 = -1;
    for (int j = 0; j < nb; ++j) {
      const float d = a.norms(i) + b.norms(j) - 2 * dot(i, j);
      if (d < d1)
        d2 = d1, d1 = d, j1 = j;
      else if (d < d2)
        d2 = d;
      if (d < d1b[j])
        d2b[j] = d1b[j], d1b[j] = d, i1b[j] = i;
      else if (d < d2b[j])
        d2b[j] = d;
    }
    if (d1 < r2 * d2) best_ab[i] = j1;
    distance[i] = std::sqrt(std::max(d1, 0.f));
  }
  for (int j = 0; j < nb; ++j)
    if (d1b[j] < r2 * d2b[j]) best_ba[j] = i1b[j];
  std::vector<cv::DMatch> out;
  for (int i = 0; i < na; ++i)
    if (best_ab[i] >= 0 && best_ba[best_ab[i]] == i) out.emplace_back(i, best_ab[i], distance[i]);
  return out;
}

// Per camera group with pairs inside it, the focal length from the pairs' fundamental matrices
// (pixels, USAC MAGSAC++), written into every camera of the group where the estimate is distinct.
void EstimateGroupFocals(const std::vector<std::pair<int, int>>& pairs,
                         const std::vector<std::vector<cv::DMatch>>& pair_matches,
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
      for (const auto& m : pair_matches[p]) pi.push_back(pixels[i][m.queryIdx]), pj.push_back(pixels[j][m.trainIdx]);
      cv::Mat mask;
      const cv::Mat f = cv::findFundamentalMat(pi, pj, cv::USAC_MAGSAC, 2.0 * options.ransac_threshold_px,
                                               options.ransac_confidence, mask);
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
    int first = -1;
    for (int p = 0; p < num_pairs; ++p)
      if (fundamentals[p] && group[pairs[p].first] == g) f.push_back(*fundamentals[p]);
    for (size_t k = 0; k < group.size() && first < 0; ++k)
      if (group[k] == g) first = static_cast<int>(k);
    const Camera& c = (*cameras)[first];
    const FocalEstimate e = EstimateFocalFromFundamentals(f, c.width, c.height, options.focal_estimation);
    if (!e.distinct) {
      LOG_INFO("{} and its camera group: focal length not determined by {} fundamental matrices; the prior {:.1f} px "
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

void CheckImageSizes(const std::vector<Image>& images, const std::vector<Camera>& cameras,
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

ViewGraph BuildViewGraph(const std::vector<Image>& images, const std::vector<Camera>& cameras,
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
  std::vector<Features> features(n);
  std::vector<std::vector<cv::Point2d>> pixels(n);
  graph.keypoints.resize(n);
  const Timer timer;
  // Images, then pairs, in parallel (OpenCV's pool: all cores, or cv::setNumThreads). Each item
  // writes only its own slot, so the graph is the same whatever the thread count.
  cv::parallel_for_(cv::Range(0, n), [&](const cv::Range& range) {
    cv::Ptr<cv::SIFT> sift = cv::SIFT::create(options.max_features, 3, options.contrast_threshold);
    for (int k = range.start; k < range.end; ++k) {
      const int up = EffectiveUpsample(options, std::max(images[k].width, images[k].height));
      cv::Mat gray = ToGray8(images[k]);
      if (up > 1) cv::resize(gray, gray, cv::Size(), up, up, cv::INTER_LINEAR);
      sift->detectAndCompute(gray, cv::noArray(), features[k].keypoints, features[k].descriptors);
      const cv::Mat& desc = features[k].descriptors;
      features[k].eigen.resize(desc.rows, desc.cols);
      for (int r = 0; r < desc.rows; ++r)
        for (int c = 0; c < desc.cols; ++c) features[k].eigen(r, c) = desc.at<float>(r, c);
      features[k].norms = features[k].eigen.rowwise().squaredNorm();
      for (const auto& kp : features[k].keypoints) {
        // OpenCV puts pixel centres at integer coordinates, nerfreg at +0.5; an image enlarged by
        // `up` (pixel-area aligned, as cv::resize is) maps x_up + 0.5 = up * (x + 0.5).
        const Eigen::Vector2d uv((kp.pt.x + 0.5) / up, (kp.pt.y + 0.5) / up);
        graph.keypoints[k].push_back(uv);
        pixels[k].push_back({uv.x(), uv.y()});
      }
    }
  });
  const double seconds_features = timer.Seconds();
  std::vector<std::pair<int, int>> pairs = pairs_in;
  if (pairs.empty())
    for (int i = 0; i < n; ++i)
      for (int j = i + 1; j < n; ++j) pairs.push_back({i, j});
  const int num_pairs = static_cast<int>(pairs.size());
  std::vector<std::vector<cv::DMatch>> pair_matches(num_pairs);
  cv::parallel_for_(cv::Range(0, num_pairs), [&](const cv::Range& range) {
    for (int p = range.start; p < range.end; ++p)
      pair_matches[p] = MatchMutualRatio(features[pairs[p].first], features[pairs[p].second], options.ratio);
  });
  const double seconds_matching = timer.Seconds() - seconds_features;
  if (options.estimate_focal) {
    std::vector<int> group = camera_group;
    if (group.empty())
      for (int k = 0; k < n; ++k) group.push_back(images[k].width * 100003 + images[k].height);
    EstimateGroupFocals(pairs, pair_matches, pixels, group, options, names, &graph.cameras);
  }
  const double seconds_focal = timer.Seconds() - seconds_features - seconds_matching;
  std::vector<std::vector<cv::Point2d>> normalised(n);
  for (int k = 0; k < n; ++k)
    for (const auto& uv : graph.keypoints[k]) {
      const Eigen::Vector3d d = graph.cameras[k].CamFromImg(uv);
      normalised[k].push_back({d.x(), d.y()});
    }
  std::vector<std::optional<ViewGraphEdge>> pair_edges(num_pairs);
  const cv::Mat identity_k = cv::Mat::eye(3, 3, CV_64F);
  cv::parallel_for_(cv::Range(0, num_pairs), [&](const cv::Range& range) {
    for (int p = range.start; p < range.end; ++p) {
      const auto [i, j] = pairs[p];
      const std::vector<cv::DMatch>& matches = pair_matches[p];
      if (static_cast<int>(matches.size()) < options.min_inliers) continue;
      std::vector<cv::Point2d> pi, pj;
      for (const auto& m : matches) {
        pi.push_back(normalised[i][m.queryIdx]);
        pj.push_back(normalised[j][m.trainIdx]);
      }
      // Normalised coordinates: the pixel threshold becomes threshold / focal.
      const double f = 0.25 * (graph.cameras[i].fx + graph.cameras[i].fy + graph.cameras[j].fx + graph.cameras[j].fy);
      cv::Mat mask;
      cv::Mat e = cv::findEssentialMat(pi, pj, identity_k, cv::RANSAC, options.ransac_confidence,
                                       options.ransac_threshold_px / f, mask);
      if (e.rows != 3 || e.cols != 3) continue;  // degenerate, or several solutions stacked
      cv::Mat r, t;
      const int inliers = cv::recoverPose(e, pi, pj, identity_k, r, t, mask);
      if (inliers < options.min_inliers) continue;
      Eigen::Matrix3d rot;
      Eigen::Vector3d trans;
      for (int a = 0; a < 3; ++a) {
        trans(a) = t.at<double>(a);
        for (int b = 0; b < 3; ++b) rot(a, b) = r.at<double>(a, b);
      }
      ViewGraphEdge edge;
      edge.i = i;
      edge.j = j;
      edge.num_matches = static_cast<int>(matches.size());
      edge.num_inliers = inliers;
      edge.j_from_i = Rigid3d(rot, trans.normalized());
      for (size_t m = 0; m < matches.size(); ++m) {
        if (mask.at<uint8_t>(static_cast<int>(m)) != 0)
          edge.inlier_matches.push_back({matches[m].queryIdx, matches[m].trainIdx});
      }
      pair_edges[p] = std::move(edge);
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

}  // namespace nerfreg
