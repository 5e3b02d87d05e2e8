#include "nerfreg/sfm/sfm_quality.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "nerfreg/util/error.h"
#include "nerfreg/util/stats.h"

namespace nerfreg {
namespace {

std::string Fmt(double v) {
  std::ostringstream s;
  s.precision(3);
  s << v;
  return s.str();
}

}  // namespace

void SfmQualityOptions::Check() const {
  if (min_image_side_px < 0) ThrowInputError("SfmQualityOptions", "min_image_side_px", ">= 0");
  if (min_points_per_image < 0) ThrowInputError("SfmQualityOptions", "min_points_per_image", ">= 0");
  if (min_multiview_points_per_image < 0)
    ThrowInputError("SfmQualityOptions", "min_multiview_points_per_image", ">= 0");
  if (!(min_median_triangulation_angle_deg >= 0)) {
    ThrowInputError("SfmQualityOptions", "min_median_triangulation_angle_deg", ">= 0");
  }
}

std::string SmallImagesProblem(int min_image_side_px, const SfmQualityOptions& options) {
  if (min_image_side_px >= options.min_image_side_px) return "";
  return "images of " + std::to_string(min_image_side_px) + " px on their short side (at least " +
         std::to_string(options.min_image_side_px) + " are needed)";
}

SfmQuality AssessSfm(const SfmResult& result, const std::vector<Camera>& cameras, const SfmQualityOptions& options) {
  options.Check();
  SfmQuality q;
  const size_t n = result.posed.size();
  q.points_per_image.assign(n, 0);
  std::vector<int> multiview(n, 0);
  q.min_image_side_px = cameras.empty() ? 0 : std::min(cameras[0].width, cameras[0].height);
  for (size_t k = 0; k < n && k < cameras.size(); ++k) {
    if (result.posed[k]) q.min_image_side_px = std::min({q.min_image_side_px, cameras[k].width, cameras[k].height});
  }
  std::vector<double> track_lengths, angles;
  for (const SfmPoint& p : result.points) {
    track_lengths.push_back(static_cast<double>(p.elements.size()));
    std::vector<Eigen::Vector3d> rays;
    for (const TrackElement& e : p.elements) {
      if (e.image < 0 || static_cast<size_t>(e.image) >= n) continue;
      ++q.points_per_image[e.image];
      if (p.elements.size() >= 3) ++multiview[e.image];
      const Rigid3d& cam = result.cam_from_world[e.image];
      const Eigen::Vector3d centre = -(cam.rotation.conjugate() * cam.translation);
      rays.push_back((p.x_in_world - centre).normalized());
    }
    double widest = 0;
    for (size_t a = 0; a < rays.size(); ++a)
      for (size_t b = a + 1; b < rays.size(); ++b) {
        widest = std::max(widest, std::acos(std::clamp(rays[a].dot(rays[b]), -1.0, 1.0)));
      }
    angles.push_back(widest * 180.0 / M_PI);
  }
  std::vector<double> per_image, multiview_per_image;  // over the posed images
  for (size_t k = 0; k < n; ++k) {
    if (!result.posed[k]) continue;
    per_image.push_back(q.points_per_image[k]);
    multiview_per_image.push_back(multiview[k]);
  }
  const auto min_or_zero = [](const std::vector<double>& v) {
    return v.empty() ? 0 : static_cast<int>(*std::min_element(v.begin(), v.end()));
  };
  q.min_points_per_image = min_or_zero(per_image);
  q.min_multiview_points_per_image = min_or_zero(multiview_per_image);
  q.median_points_per_image = UpperMedian(per_image);
  q.median_track_length = UpperMedian(track_lengths);
  q.median_triangulation_angle_deg = UpperMedian(angles);

  if (!result.degenerate.empty()) q.problems.push_back(result.degenerate);
  if (const std::string small = SmallImagesProblem(q.min_image_side_px, options); !small.empty()) {
    q.problems.push_back(small + ": a sub-pixel reprojection error there does not pin the cameras down");
  }
  if (q.min_points_per_image < options.min_points_per_image) {
    q.problems.push_back("an image observes only " + std::to_string(q.min_points_per_image) +
                         " triangulated points (at least " + std::to_string(options.min_points_per_image) +
                         " are needed)");
  }
  // (Said once: an image short of points is short of multi-view points too.)
  if (q.min_points_per_image >= options.min_points_per_image &&
      q.min_multiview_points_per_image < options.min_multiview_points_per_image) {
    q.problems.push_back("an image observes only " + std::to_string(q.min_multiview_points_per_image) +
                         " points that 3 or more images see (at least " +
                         std::to_string(options.min_multiview_points_per_image) +
                         " are needed): its pose rests on pairs alone");
  }
  if (q.median_triangulation_angle_deg < options.min_median_triangulation_angle_deg) {
    q.problems.push_back("points are triangulated under " + Fmt(q.median_triangulation_angle_deg) +
                         " deg (median; at least " + Fmt(options.min_median_triangulation_angle_deg) +
                         " are needed): depth and motion are not separable");
  }
  return q;
}

}  // namespace nerfreg
