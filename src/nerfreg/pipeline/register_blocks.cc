#include "nerfreg/pipeline/register_blocks.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "nerfreg/render/point_splat.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/image.h"

namespace nerfreg {

// Before / after: source in orange, target in blue, from three fixed viewpoints, beside `out`.
void WriteRegistrationOverlays(const std::string& out, const BlockRegistrationResult& result) {
  const Eigen::Matrix3Xd& src = result.source_cloud;
  const Eigen::Matrix3Xd& tgt = result.target_cloud;
  const Sim3d& target_from_source = result.target_from_source;
  const std::string stem = out.substr(0, out.size() - LowerExtension(out).size());
  auto subsample = [](const Eigen::Matrix3Xd& m) {
    const Eigen::Index step = std::max<Eigen::Index>(1, m.cols() / 20000);
    Eigen::Matrix3Xd s(3, (m.cols() + step - 1) / step);
    for (Eigen::Index i = 0, k = 0; i < m.cols(); i += step, ++k) s.col(k) = m.col(i);
    return s;
  };
  const Eigen::Matrix3Xd s_small = subsample(src), t_small = subsample(tgt);
  Eigen::Matrix3Xd moved(3, s_small.cols());
  for (Eigen::Index i = 0; i < s_small.cols(); ++i) moved.col(i) = target_from_source * Eigen::Vector3d(s_small.col(i));
  const Eigen::Vector3d centre = t_small.cols() ? Eigen::Vector3d(t_small.rowwise().mean()) : Eigen::Vector3d::Zero();
  const Eigen::Vector3f orange(0.95f, 0.5f, 0.1f), blue(0.1f, 0.35f, 0.9f);
  WriteImage(stem + "_before.png", ThreeViewOverlay({{s_small, orange}, {t_small, blue}}, centre, 5.0));
  WriteImage(stem + "_after.png", ThreeViewOverlay({{moved, orange}, {t_small, blue}}, centre, 5.0));
}

std::string RegistrationSummary(const BlockRegistrationResult& r, const std::string& out) {
  const Eigen::AngleAxisd aa(r.target_from_source.rotation);
  const Eigen::Vector3d& t = r.target_from_source.translation;
  const std::string stem = out.substr(0, out.size() - LowerExtension(out).size());
  std::string agree = "one candidate only";
  if (r.agreeing_candidates >= 0) {
    agree = fmt::format("{} of {} other candidates agree", r.agreeing_candidates, r.candidates.size() - 1);
  }
  std::string s = fmt::format("{:<11} {} ({}, scale {}), {:.1f} s\n", r.status, r.method,
                              RegistrationMethodName(r.options.method), ScaleModeName(r.options.scale), r.seconds);
  if (!r.status_reason.empty()) s += fmt::format("{:<11} {}\n", "why", r.status_reason);
  if (r.reverse.is_object() && r.reverse.value("kept", false)) {
    const Json& other = r.reverse["other_way"];
    s += fmt::format("{:<11} source -> target was {} (confidence {:.2f}): the target onto the source, inverted\n",
                     "other way", other.value("status", std::string()), other.value("confidence", 0.0));
  }
  s += fmt::format("{:<11} {:.2f} deg about ({:.3f}, {:.3f}, {:.3f})\n", "rotation", aa.angle() * 180 / M_PI,
                   aa.axis().x(), aa.axis().y(), aa.axis().z());
  s += fmt::format("{:<11} ({:.4f}, {:.4f}, {:.4f}), |t| {:.4f} (target units)\n", "translation", t.x(), t.y(), t.z(),
                   t.norm());
  s += fmt::format("{:<11} {:.4f}\n", "scale", r.target_from_source.scale);
  s += fmt::format("{:<11} {:.2f}, {}\n", "confidence", r.confidence, agree);
  s += fmt::format("{:<11} {}, {}_before.png, {}_after.png\n", "written", out, stem, stem);
  return s;
}

}  // namespace nerfreg
