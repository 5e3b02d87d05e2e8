// The field queries grid extraction runs, against plain computations of the same quantities: the
// view-averaged colour against six full field passes, the surface field against a ray-by-ray march.
#include "nerfreg/nerf/field_queries.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "nerfreg/geometry/conventions.h"
#include "nerfreg/nerf/nerf_block.h"
#include "nerfreg/nerf/test_train_options.h"

namespace nerfreg {
namespace {

// An untrained block (random field) whose occupancy grid leaves about a third of its cells empty,
// seen by `views` cameras on a circle of radius 3 around it.
NerfBlock QueryTestBlock(int views, const FieldOptions* field = nullptr) {
  const NerfTrainOptions o = TinyNerfTrainOptions(1);
  NerfBlock b = NerfBlock::Create(field ? *field : o.field, o.grid, o.march, 3);
  torch::NoGradGuard no_grad;
  // Larger weights than an initialisation's: densities from ~0 to well above 10 (rays end inside
  // the box) and colours that change with the direction.
  torch::manual_seed(4);
  for (auto& p : b.field->named_parameters()) {
    if (p.key() == "table") {
      p.value().normal_(0, 1);
    } else {
      p.value().mul_(2.5);
    }
  }
  const std::int64_t g = o.grid.resolution;
  b.grid->SetState(torch::ones({g, g, g}), torch::rand({g, g, g}) > 0.35);
  for (int i = 0; i < views; ++i) {
    const double a = 2 * M_PI * i / views;
    const Eigen::Vector3d centre(3 * std::cos(a), 3 * std::sin(a), 0.5 * std::sin(3 * a));
    const Eigen::Vector3d fwd = -centre.normalized();
    const Eigen::Vector3d right = fwd.cross(Eigen::Vector3d::UnitZ()).normalized();
    Eigen::Matrix3d world_from_cam;
    world_from_cam << right, fwd.cross(right), fwd;
    Frame f;
    f.name = f.file_path = "r_" + std::to_string(i) + ".png";
    f.camera = Camera::Pinhole(32, 32, 30, 30, 16, 16);
    f.cam_from_world = Rigid3d(Eigen::Matrix3d(world_from_cam.transpose()), -world_from_cam.transpose() * centre);
    f.split = "train";
    b.cameras.frames.push_back(f);
  }
  return b;
}

torch::Tensor QueryTestPoints(std::int64_t n, double half) {
  torch::manual_seed(11);
  return (torch::rand({n, 3}) * 2 - 1) * half;
}

TEST(FieldQueries, ViewAveragedColorIsTheMeanOfSixFullFieldPasses) {
  NerfBlock block = QueryTestBlock(1);
  // A moved block: the directions go into the field's frame as BlockForward takes them there.
  block.world_from_field =
      Sim3d(1.3, Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, -2, 0.5).normalized())),
            Eigen::Vector3d(0.2, -0.4, 0.1));
  const torch::Tensor x = QueryTestPoints(3000, 1.8);
  const torch::Tensor fast = ViewAveragedColor(block, x);
  torch::Tensor slow = torch::zeros({x.size(0), 3});
  torch::Tensor first;
  for (const auto& d :
       std::vector<std::vector<float>>{{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}}) {
    const torch::Tensor rgb = BlockForward(block, x, torch::tensor(d).expand({x.size(0), 3}).contiguous()).second;
    if (!first.defined()) first = rgb;
    slow += rgb / 6.0;
  }
  ASSERT_EQ(fast.sizes(), slow.sizes());
  EXPECT_LT((fast - slow).abs().max().item<float>(), 1e-6f);
  // The directions matter on this field: one alone is far from the mean, so a head fed the wrong
  // direction (or the features in the wrong place) fails above.
  EXPECT_GT((first - slow).abs().max().item<float>(), 1e-2f);
}

TEST(FieldQueries, ColorsAlongAreForwardsColoursInBothFlavors) {
  FieldOptions ngp = TinyNerfTrainOptions(1).field;
  ngp.flavor = "instant-ngp";
  ngp.encoding.grid_rule = "instant-ngp";
  ngp.axis_order = {1, 2, 0};
  for (const FieldOptions* f : std::vector<const FieldOptions*>{nullptr, &ngp}) {
    NerfBlock block = QueryTestBlock(1, f);
    torch::NoGradGuard no_grad;
    const torch::Tensor x = QueryTestPoints(500, 1.4);
    const torch::Tensor dirs =
        torch::nn::functional::normalize(torch::randn({5, 3}), torch::nn::functional::NormalizeFuncOptions().dim(1));
    const torch::Tensor along = block.field->ColorsAlong(x, dirs);  // [N, 5, 3]
    ASSERT_EQ(along.sizes(), torch::IntArrayRef({500, 5, 3}));
    for (int d = 0; d < 5; ++d) {
      const torch::Tensor rgb = block.field->Forward(x, dirs[d].expand({500, 3}).contiguous()).second;
      EXPECT_LT((along.select(1, d) - rgb).abs().max().item<float>(), 1e-6f) << "flavor " << block.field_options.flavor;
    }
  }
}

// S(X) computed ray by ray, sample by sample, in doubles (the spec's definition, as
// SurfaceFieldOptions documents it); the samples are placed as the library places them.
std::vector<double> PlainSurfaceField(NerfBlock& block, const torch::Tensor& points, const SurfaceFieldOptions& o) {
  torch::NoGradGuard no_grad;
  const auto& fo = block.field_options;
  const auto mn = torch::tensor(fo.aabb_min, torch::kFloat32), mx = torch::tensor(fo.aabb_max, torch::kFloat32);
  const std::int64_t g = block.grid->resolution();
  const auto occupied = block.grid->occupied();
  const double step = block.march.step_size;
  std::vector<double> s(points.size(0), 0.0);
  for (const Frame& f : block.cameras.frames) {
    const Eigen::Vector3d c = CameraCenter(f.cam_from_world);
    const auto origin = torch::tensor({float(c.x()), float(c.y()), float(c.z())});
    for (std::int64_t i = 0; i < points.size(0); ++i) {
      const Eigen::Vector3d p(points[i][0].item<float>(), points[i][1].item<float>(), points[i][2].item<float>());
      const Eigen::Vector3d pc = f.cam_from_world * p;
      const double u = f.camera.fx * pc.x() / pc.z() + f.camera.cx, v = f.camera.fy * pc.y() / pc.z() + f.camera.cy;
      if (!(pc.z() > 0.05 && u >= 0 && u < f.camera.width && v >= 0 && v < f.camera.height)) continue;
      const auto x = points[i];
      const auto dist = (x - origin).norm();
      const auto dir = (x - origin) / dist;
      const auto inv = 1.0 / dir;
      const auto t0 = torch::clamp_min(torch::minimum((mn - origin) * inv, (mx - origin) * inv).amax(), 0.0);
      const double d = dist.item<double>();
      const double end = o.mode == "window" ? d + 0.5 * o.window : d;
      double transmit = 1, measure = 0;
      for (std::int64_t k = 0;; ++k) {
        const auto t = t0 + (torch::tensor(float(k)) + 0.5) * step;
        if (t.item<double>() > end) break;
        const auto pos = origin + dir * t;
        const auto cell = ((pos - mn) / (mx - mn) * g).floor().to(torch::kInt64);
        if (!((cell >= 0) & (cell < g)).all().item<bool>() || !occupied[cell[0]][cell[1]][cell[2]].item<bool>())
          continue;
        const double sigma = block.field->Density(pos.view({1, 3})).item<double>();
        const double alpha = 1 - std::exp(-sigma * step), w = alpha * transmit;
        if (o.mode == "window") {
          if (t.item<double>() >= d - 0.5 * o.window) measure += w;
        } else if (o.mode == "opacity") {
          measure += w;
        } else {
          measure = std::max(measure, w);
        }
        transmit *= 1 - alpha;
      }
      s[i] = std::max(s[i], measure);
    }
  }
  return s;
}

TEST(FieldQueries, SurfaceFieldIsThePlainMarchInEveryMode) {
  NerfBlock block = QueryTestBlock(5);
  block.march.step_size = 0.06;  // fewer samples for the plain march
  const torch::Tensor x = QueryTestPoints(40, 1.3);
  for (const std::string mode : {"window", "opacity", "max_weight"}) {
    SurfaceFieldOptions o;
    o.mode = mode;
    o.window = 0.3;
    const std::vector<double> plain = PlainSurfaceField(block, x, o);
    o.min_transmittance = 0;
    const torch::Tensor every = SurfaceField(block, x, o);
    o.min_transmittance = 0.25;
    const torch::Tensor cut = SurfaceField(block, x, o);
    double spread = 0, lo = 1, hi = 0;
    for (std::int64_t i = 0; i < x.size(0); ++i) {
      EXPECT_NEAR(every[i].item<double>(), plain[i], 2e-6) << mode << " point " << i;
      // Stopping a ray once less than a quarter of it goes on changes S by less than that.
      EXPECT_NEAR(cut[i].item<double>(), plain[i], 0.25) << mode << " point " << i;
      lo = std::min(lo, plain[i]), hi = std::max(hi, plain[i]);
    }
    spread = hi - lo;
    EXPECT_GT(spread, 0.1) << mode << ": the field must vary for the comparison to mean anything";
    // Rays did stop early (else the second comparison tests nothing).
    const double cut_diff = (cut - every).abs().max().item<double>();
    if (mode == "opacity") EXPECT_GT(cut_diff, 0.01);
    std::printf("%s: S in [%.3f, %.3f], early stop changed S by %.2g at most\n", mode.c_str(), lo, hi, cut_diff);
  }
}

}  // namespace
}  // namespace nerfreg
