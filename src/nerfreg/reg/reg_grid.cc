#include "nerfreg/reg/reg_grid.h"

#include <cstring>
#include <stdexcept>

#include <Eigen/Geometry>

#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/torch_archive.h"

namespace nerfreg {

Eigen::Matrix3Xd PointsToEigen(const torch::Tensor& xyz) {
  TORCH_CHECK(xyz.dim() == 2 && xyz.size(1) == 3, "PointsToEigen: points must be [N, 3]");
  const torch::Tensor c = xyz.to(torch::kFloat64).cpu().contiguous();
  Eigen::Matrix3Xd m(3, c.size(0));
  if (c.size(0) > 0) std::memcpy(m.data(), c.data_ptr<double>(), sizeof(double) * 3 * c.size(0));
  return m;
}
namespace {

constexpr const char* kFormatTag = "nerfreg-reg-grid";

Json VectorJson(const Eigen::Vector3d& v) { return Json::array({v.x(), v.y(), v.z()}); }

}  // namespace

torch::Tensor RegGrid::MaskedXyz() const { return xyz.index({mask}); }
torch::Tensor RegGrid::Occupied() const { return (rgba[3] > 0) | mask; }
torch::Tensor RegGrid::OccupiedXyz() const { return xyz.index({Occupied()}); }
torch::Tensor RegGrid::MaskedSurface() const { return surface.index({mask}); }

void RegGrid::Check() const {
  auto fail = [](const std::string& what) { throw std::invalid_argument("RegGrid: " + what); };
  if (!surface.defined() || surface.dim() != 3) fail("surface must be [D, D, D]");
  const std::int64_t d = surface.size(0);
  if (d < 2 || surface.size(1) != d || surface.size(2) != d) fail("surface must be cubic [D, D, D]");
  if (!rgba.defined() || rgba.sizes() != torch::IntArrayRef({4, d, d, d})) fail("rgba must be [4, D, D, D]");
  if (!xyz.defined() || xyz.sizes() != torch::IntArrayRef({d, d, d, 3})) fail("xyz must be [D, D, D, 3]");
  if (!mask.defined() || mask.sizes() != torch::IntArrayRef({d, d, d}) || mask.scalar_type() != torch::kBool) {
    fail("mask must be [D, D, D] bool");
  }
  if (rgba.scalar_type() != torch::kFloat32 || xyz.scalar_type() != torch::kFloat32 ||
      surface.scalar_type() != torch::kFloat32) {
    fail("rgba, xyz and surface must be float32");
  }
  const Eigen::Vector3d side = aabb_max - aabb_min;
  if (!(side.minCoeff() > 0) || std::abs(side.x() - side.y()) > 1e-6 * side.x() ||
      std::abs(side.x() - side.z()) > 1e-6 * side.x()) {
    fail("the box must be a non-empty cube");
  }
}

void SaveRegGrid(const RegGrid& grid, const std::string& path) {
  grid.Check();
  const Json meta = {{"format", kFormatTag},
                     {"version", kRegGridVersion},
                     {"aabb_min", VectorJson(grid.aabb_min)},
                     {"aabb_max", VectorJson(grid.aabb_max)},
                     {"source", grid.source},
                     {"variant", grid.variant}};
  torch::serialize::OutputArchive archive;
  archive.write("meta", StringTensor(meta.dump()));
  archive.write("rgba", grid.rgba.contiguous());
  archive.write("xyz", grid.xyz.contiguous());
  archive.write("surface", grid.surface.contiguous());
  archive.write("mask", grid.mask.to(torch::kUInt8).contiguous());
  SaveArchiveAtomic(archive, path);
}

RegGrid LoadRegGrid(const std::string& path) {
  torch::serialize::InputArchive archive;
  const Json meta = LoadArchiveMeta(path, "registration grid", kFormatTag, kRegGridVersion, &archive);
  const JsonField m(meta, path);
  RegGrid g;
  const auto mn = m["aabb_min"].Doubles(), mx = m["aabb_max"].Doubles();
  if (mn.size() != 3 || mx.size() != 3) ThrowInputError(path, "aabb_min/aabb_max", "3 numbers each");
  g.aabb_min = Eigen::Vector3d(mn[0], mn[1], mn[2]);
  g.aabb_max = Eigen::Vector3d(mx[0], mx[1], mx[2]);
  g.source = m.StringOr("source", "nerf");
  g.variant = m.StringOr("variant", "surface");
  try {
    archive.read("rgba", g.rgba);
    archive.read("xyz", g.xyz);
    archive.read("surface", g.surface);
    archive.read("mask", g.mask);
    g.mask = g.mask.to(torch::kBool);
    g.Check();
  } catch (const std::exception& e) {
    ThrowInputError(path, "", std::string("a complete registration grid (") + e.what() + ")");
  }
  return g;
}

RegGrid TransformRegGrid(const RegGrid& grid, const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation) {
  grid.Check();
  torch::NoGradGuard no_grad;
  const std::int64_t d = grid.Resolution();
  const double cell = grid.CellSize();
  const Eigen::Vector3d centre = 0.5 * (grid.aabb_min + grid.aabb_max);
  RegGrid out;
  out.source = grid.source;
  out.variant = grid.variant;
  // The same box size, centred on the moved centre.
  const Eigen::Vector3d new_centre = rotation * centre + translation;
  out.aabb_min = new_centre - 0.5 * (grid.aabb_max - grid.aabb_min);
  out.aabb_max = new_centre + 0.5 * (grid.aabb_max - grid.aabb_min);
  out.rgba = torch::zeros_like(grid.rgba);
  out.surface = torch::zeros_like(grid.surface);
  out.mask = torch::zeros_like(grid.mask);
  // Pull resampling: every voxel of the new grid takes the content of the source voxel its centre
  // comes from (nearest neighbour), so a rotation leaves no holes; its sample point is its own
  // centre jittered within the cell, as extraction does (a different sample of the same surface).
  const auto idx = torch::arange(d, torch::kFloat32);
  const auto mesh = torch::meshgrid({idx, idx, idx}, "ij");
  const auto mn = torch::tensor({float(out.aabb_min.x()), float(out.aabb_min.y()), float(out.aabb_min.z())});
  torch::Generator gen = at::detail::createCPUGenerator(0);
  out.xyz = mn + (torch::stack({mesh[0], mesh[1], mesh[2]}, -1) + torch::rand({d, d, d, 3}, gen)) * float(cell);
  const auto centres = (mn + (torch::stack({mesh[0], mesh[1], mesh[2]}, -1) + 0.5) * float(cell)).reshape({-1, 3});
  const Eigen::Matrix3f rt = rotation.transpose().cast<float>();  // source_from_new rotation
  const auto Rinv = torch::from_blob(const_cast<float*>(rt.data()), {3, 3}, torch::kFloat32).t().clone();  // row-major
  const auto t = torch::tensor({float(translation.x()), float(translation.y()), float(translation.z())});
  const auto back = (centres - t).matmul(Rinv.t());  // [D^3, 3] in the source frame
  const auto src_mn = torch::tensor({float(grid.aabb_min.x()), float(grid.aabb_min.y()), float(grid.aabb_min.z())});
  const auto ijk = ((back - src_mn) / float(cell)).floor().to(torch::kInt64);
  const auto inside = ((ijk >= 0) & (ijk < d)).all(1);
  const auto keep = inside.nonzero().squeeze(1);
  const auto s = ijk.index_select(0, keep);
  const auto flat_src = (s.select(1, 0) * d + s.select(1, 1)) * d + s.select(1, 2);
  out.surface.view({-1}).index_copy_(0, keep, grid.surface.reshape(-1).index_select(0, flat_src));
  out.mask.view({-1}).index_copy_(0, keep, grid.mask.reshape(-1).index_select(0, flat_src));
  out.rgba.view({4, -1}).index_copy_(1, keep, grid.rgba.reshape({4, -1}).index_select(1, flat_src));
  return out;
}

RegGrid MirrorRegGrid(const RegGrid& grid, Eigen::Matrix4d* mirrored_from_grid) {
  grid.Check();
  torch::NoGradGuard no_grad;
  const double cx = 0.5 * (grid.aabb_min.x() + grid.aabb_max.x());
  RegGrid out = grid;
  // Voxel i along x holds [min + i cell, min + (i + 1) cell); mirrored about the centre it lands
  // on voxel D - 1 - i, so a flip of the x axis (dim 1 of rgba, dim 0 of the others) is exact.
  out.rgba = grid.rgba.flip({1}).contiguous();
  out.surface = grid.surface.flip({0}).contiguous();
  out.mask = grid.mask.flip({0}).contiguous();
  out.xyz = grid.xyz.flip({0}).clone();
  out.xyz.select(3, 0).mul_(-1).add_(2 * cx);
  if (mirrored_from_grid) {
    mirrored_from_grid->setIdentity();
    (*mirrored_from_grid)(0, 0) = -1;
    (*mirrored_from_grid)(0, 3) = 2 * cx;
  }
  return out;
}

void MirrorRegGridPair(RegGrid* source, RegGrid* target, Eigen::Matrix4d* target_from_source) {
  Eigen::Matrix4d ms, mt;
  *source = MirrorRegGrid(*source, &ms);
  *target = MirrorRegGrid(*target, &mt);
  *target_from_source = mt * *target_from_source * ms;  // ms is its own inverse
}

RegGrid RecolourRegGrid(const RegGrid& grid, const std::array<std::int64_t, 3>& permutation,
                        const std::array<double, 3>& gain) {
  grid.Check();
  torch::NoGradGuard no_grad;
  std::array<bool, 3> seen = {false, false, false};
  for (const auto c : permutation) {
    if (c < 0 || c > 2 || seen[c]) throw std::invalid_argument("RecolourRegGrid: permutation is not one of 0, 1, 2");
    seen[c] = true;
  }
  RegGrid out = grid;
  out.rgba = grid.rgba.clone();
  for (int c = 0; c < 3; ++c) {
    out.rgba.select(0, c).copy_((grid.rgba.select(0, permutation[c]) * gain[c]).clamp(0, 1));
  }
  return out;
}

double GridOverlap(const RegGrid& source, const RegGrid& target, const Eigen::Matrix4d& target_from_source) {
  torch::NoGradGuard no_grad;
  const auto pts = source.MaskedXyz();  // [M, 3]
  if (pts.size(0) == 0) return 0;
  const Eigen::Matrix4f m = target_from_source.cast<float>();
  const auto T =
      torch::from_blob(const_cast<float*>(m.data()), {4, 4}, torch::kFloat32).t().to(pts.device());  // row-major
  const auto moved = pts.matmul(T.slice(0, 0, 3).slice(1, 0, 3).t()) + T.slice(0, 0, 3).select(1, 3);
  const std::int64_t d = target.Resolution();
  // The target mask dilated by one cell.
  const auto dil =
      torch::max_pool3d(target.mask.to(torch::kFloat32).unsqueeze(0).unsqueeze(0), 3, 1, 1).squeeze(0).squeeze(0) > 0;
  const auto mn = torch::tensor({float(target.aabb_min.x()), float(target.aabb_min.y()), float(target.aabb_min.z())})
                      .to(pts.device());
  const auto ijk = ((moved - mn) / float(target.CellSize())).floor().to(torch::kInt64);
  const auto inside = ((ijk >= 0) & (ijk < d)).all(1);
  const auto c = ijk.clamp(0, d - 1);
  const auto hit = dil.index({c.select(1, 0), c.select(1, 1), c.select(1, 2)}) & inside;
  return hit.to(torch::kFloat64).mean().item<double>();
}

}  // namespace nerfreg
