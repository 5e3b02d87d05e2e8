#include "nerfreg/reg/registration_input.h"

#include <fmt/format.h>

#include "nerfreg/data/sim3_apply.h"
#include "nerfreg/data/splat_ply.h"
#include "nerfreg/data/ngp_snapshot.h"
#include "nerfreg/nerf/field_queries.h"
#include "nerfreg/nerf/ngp_import.h"
#include "nerfreg/reg/reg_grid.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"

namespace nerfreg {

Eigen::Matrix3Xd NerfBlockInput::OccupiedPoints(double min_density, unsigned seed, bool shell) {
  return PointsToEigen(ExtractOccupiedPoints(*block_, min_density, seed, shell).xyz);
}

torch::Tensor SplatDensity(const SplatField& field, const torch::Tensor& positions, torch::Tensor* rgb) {
  TORCH_CHECK(positions.dim() == 2 && positions.size(1) == 3, "SplatDensity: positions must be [N, 3]");
  const torch::Tensor p = positions.detach().to(torch::kCPU, torch::kDouble).contiguous();
  const Eigen::Map<const Eigen::Matrix3Xd> points(p.data_ptr<double>(), 3, p.size(0));
  Eigen::Matrix3Xd colour;
  const Eigen::VectorXd sigma = field.Density(points, rgb ? &colour : nullptr);
  if (rgb) {
    *rgb =
        torch::from_blob(colour.data(), {colour.cols(), 3}, torch::kDouble).to(torch::kFloat32).to(positions.device());
  }
  return torch::from_blob(const_cast<double*>(sigma.data()), {sigma.size()}, torch::kDouble)
      .to(torch::kFloat32)
      .to(positions.device());
}

DensityField SplatInput::Field() {
  DensityField f;
  const SplatField* field = &field_;
  f.density = [field](const torch::Tensor& x) { return SplatDensity(*field, x); };
  f.box = field_.Bounds();
  return f;
}

RegGrid SplatInput::ExtractGrid(const GridExtractionOptions& options) {
  GridFieldQueries q;
  q.source = "splats";
  const SplatField* field = &field_;
  q.density = [field](const torch::Tensor& x) { return SplatDensity(*field, x); };
  q.color = [field](const torch::Tensor& x) {
    torch::Tensor rgb;
    SplatDensity(*field, x, &rgb);
    return rgb;
  };
  const Eigen::Vector3d centre =
      field_.size() > 0 ? Eigen::Vector3d(field_.Bounds().center()) : Eigen::Vector3d::Zero();
  return ExtractRegGridFromField(q, centre, options);
}

Eigen::Matrix3Xd SplatInput::OccupiedPoints(double min_density, unsigned seed, bool /*shell*/) {
  if (field_.size() == 0) return Eigen::Matrix3Xd(3, 0);
  torch::NoGradGuard no_grad;
  const Eigen::AlignedBox3d& box = field_.Bounds();
  const double cell = box.sizes().maxCoeff() / kSplatOccupancyResolution;
  const Eigen::Vector3i dims = (box.sizes() / cell).array().ceil().cast<int>().cwiseMax(1);
  torch::Generator gen = at::detail::createCPUGenerator(seed);
  std::vector<Eigen::Vector3d> kept;
  // One slab of cells along x at a time: at most 128 x 128 points in flight.
  for (int i = 0; i < dims.x(); ++i) {
    const auto jj = torch::arange(dims.y(), torch::kDouble), kk = torch::arange(dims.z(), torch::kDouble);
    const auto grid = torch::meshgrid({jj, kk}, "ij");
    const auto ijk = torch::stack({torch::full_like(grid[0], i), grid[0], grid[1]}, -1).reshape({-1, 3});  // [M, 3]
    const auto lo = torch::tensor({box.min().x(), box.min().y(), box.min().z()}, torch::kDouble);
    const auto pts = (lo + (ijk + torch::rand(ijk.sizes(), gen, torch::kDouble)) * cell).contiguous();  // [M, 3]
    const auto sigma = SplatDensity(field_, pts);
    const auto keep = (sigma > min_density).nonzero().squeeze(1);
    const auto sel = pts.index_select(0, keep).contiguous();
    const double* d = sel.data_ptr<double>();
    for (std::int64_t r = 0; r < sel.size(0); ++r) kept.emplace_back(d[3 * r], d[3 * r + 1], d[3 * r + 2]);
  }
  Eigen::Matrix3Xd out(3, kept.size());
  for (size_t c = 0; c < kept.size(); ++c) out.col(c) = kept[c];
  return out;
}

bool IsNgpSnapshotPath(const std::string& path) {
  const std::string ext = LowerExtension(path);
  return ext == ".ingp" || ext == ".msgpack";
}

namespace {

std::unique_ptr<RegistrationInput> LoadInFileFrame(const std::string& path, const SplatFieldOptions& splat_options,
                                                   const torch::Device& device) {
  if (IsSplatPly(path)) {
    const Splats splats = ReadSplatPly(path);
    if (splats.size() < kMinSplats) {
      ThrowInputError(path, "vertex", fmt::format("at least {} splats to register, got {}", kMinSplats, splats.size()));
    }
    return std::make_unique<SplatInput>(splats, splat_options);
  }
  if (LowerExtension(path) == ".ply") {
    ThrowInputError(path, "",
                    "a NeRF block checkpoint or a 3D Gaussian splat PLY (vertex properties f_dc_0, opacity, "
                    "scale_0, rot_0; this PLY has none)");
  }
  if (IsNgpSnapshotPath(path)) {
    NerfBlock block = SnapshotToNerfBlock(ReadNgpSnapshot(path), path);
    block.To(device);
    return std::make_unique<NerfBlockInput>(std::move(block));
  }
  return std::make_unique<NerfBlockInput>(LoadNerfBlock(path, nullptr, device));
}

}  // namespace

std::unique_ptr<RegistrationInput> LoadRegistrationInput(const std::string& path,
                                                         const SplatFieldOptions& splat_options,
                                                         const torch::Device& device,
                                                         const std::optional<Sim3d>& capture_from_file) {
  std::unique_ptr<RegistrationInput> input = LoadInFileFrame(path, splat_options, device);
  input->SetPath(path);
  if (capture_from_file) input->Move(*capture_from_file);
  return input;
}

void SplatInput::Move(const Sim3d& new_from_old) {
  const SplatFieldOptions options = field_.options();
  splats_ = TransformSplats(splats_, new_from_old);
  field_ = SplatField(splats_, options);
}

}  // namespace nerfreg
