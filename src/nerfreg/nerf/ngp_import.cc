#include "nerfreg/nerf/ngp_import.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "nerfreg/util/error.h"
#include "nerfreg/util/logging.h"

namespace nerfreg {

void NgpImportOptions::Check() const {
  if ((frame != "nerf" && frame != "ngp") || !(occupancy_threshold > 0) || steps_per_aabb < 16) {
    throw std::invalid_argument("NgpImportOptions: out of range");
  }
}

NgpFrame ImportFrame(const NgpSnapshot& s, const NgpImportOptions& options, const Dataset* cameras) {
  NgpFrame f;
  if (options.frame == "ngp") return f;
  f.axis_order = {1, 2, 0};
  f.scale = s.scale;  // the snapshot's own values, or ngp's defaults
  f.offset = s.offset;
  if (!s.has_dataset_transform && cameras) {
    if (cameras->ngp_scale) f.scale = *cameras->ngp_scale;
    if (cameras->ngp_offset) f.offset = {cameras->ngp_offset->x(), cameras->ngp_offset->y(), cameras->ngp_offset->z()};
  }
  return f;
}

namespace {

// Copies a row-major [rows, cols] block of ngp params (a matrix stored as [rows_stored, cols_stored])
// into a Linear weight [rows, cols].
void CopyMatrix(const std::vector<float>& p, std::int64_t offset, int cols_stored, torch::Tensor weight) {
  const auto src =
      torch::from_blob(const_cast<float*>(p.data() + offset), {weight.size(0), cols_stored}, torch::kFloat32);
  weight.copy_(src.slice(1, 0, weight.size(1)));
}

// Occupancy in the block's grid cells from ngp's cascades: a cell takes the finest cascade that
// contains its centre; a coarse cell over a finer cascade is the max over its children (the finer
// cascade is what instant-ngp marches there).
void ImportOccupancy(const NgpSnapshot& s, const NgpFrame& frame, const NgpImportOptions& options,
                     OccupancyGrid* grid) {
  const int g = s.density_grid_size, cascades = s.density_cascades;
  const auto raw = torch::from_blob(const_cast<float*>(s.density_grid.data()), {cascades, g, g, g},
                                    torch::kFloat32);  // [c][z][y][x]
  const double mean0 = raw[0].clamp_min(0).mean().item<double>();
  const double thr = std::min(options.occupancy_threshold, mean0);
  std::vector<torch::Tensor> occ, sigma;
  for (int c = 0; c < cascades; ++c) {
    auto o = (raw[c] > thr).to(torch::kFloat32);
    // Optical thickness -> density per block length: / ngp step at this cascade * world scale.
    auto d = raw[c].clamp_min(0) / (std::sqrt(3.0) / 1024 * std::ldexp(1.0, c)) * frame.scale;
    if (c > 0 && g >= 4) {
      const auto pool = [g](const torch::Tensor& t) {
        return torch::max_pool3d(t.view({1, 1, g, g, g}), 2).view({g / 2, g / 2, g / 2});
      };
      const auto inner = torch::indexing::Slice(g / 4, g / 4 + g / 2);
      o.index_put_({inner, inner, inner}, pool(occ.back()));
      d.index_put_({inner, inner, inner}, pool(sigma.back()));
    }
    occ.push_back(o);
    sigma.push_back(d);
  }
  const auto all_occ = torch::stack(occ).view(-1), all_sigma = torch::stack(sigma).view(-1);
  // Block cell centres -> ngp space.
  const auto centres = grid->CellCenters().to(torch::kFloat64);  // [G^3, 3] block frame
  std::vector<torch::Tensor> cols;
  for (int k = 0; k < 3; ++k)
    cols.push_back(centres.select(1, frame.axis_order[k]) * frame.scale + frame.offset[frame.axis_order[k]]);
  const auto x_ngp = torch::stack(cols, 1);
  // One cascade for every cell: the finest one containing the whole grid (its cells already hold
  // the max over finer cascades), so a cell never samples a single child of a finer cascade.
  const auto extent = (x_ngp - 0.5).abs().amax(1);  // cascade c covers extent < 2^(c-1)
  const double needed = std::ceil(std::log2(std::max(extent.max().item<double>(), 1e-9) * 2));
  const int lv = static_cast<int>(std::clamp(needed, 0.0, double(cascades - 1)));
  const auto inside = extent < std::ldexp(1.0, lv - 1);
  const auto cell = ((x_ngp - 0.5) / std::ldexp(1.0, lv) + 0.5) * g;  // [0, g) within the cascade
  const auto ic = cell.floor().clamp(0, g - 1).to(torch::kInt64);
  const auto index = ((std::int64_t(lv) * g + ic.select(1, 2)) * g + ic.select(1, 1)) * g + ic.select(1, 0);
  const int gr = grid->resolution();
  const auto occupied = (all_occ.index_select(0, index) > 0) & inside;
  const auto density = all_sigma.index_select(0, index) * inside.to(torch::kFloat32);
  grid->SetState(density.view({gr, gr, gr}), occupied.view({gr, gr, gr}));
}

}  // namespace

NerfBlock SnapshotToNerfBlock(const NgpSnapshot& s, const std::string& source, const NgpImportOptions& options,
                              const Dataset* cameras) {
  options.Check();
  const auto& dn = s.density_network;
  const auto& rn = s.rgb_network;
  if (dn.hidden_layers != 1) ThrowInputError(source, "network.n_hidden_layers", "1 (the density MLP of our field)");
  if (dn.width != rn.width)
    ThrowInputError(source, "rgb_network.n_neurons", std::to_string(dn.width) + " (as network.n_neurons)");
  if (s.sh_degree != 4) ThrowInputError(source, "dir_encoding", "spherical harmonics of degree 4");
  const NgpFrame frame = ImportFrame(s, options, cameras);
  if (s.has_dataset_transform && cameras && cameras->ngp_scale && std::abs(*cameras->ngp_scale - s.scale) > 1e-9) {
    LOG_WARN("{}: the snapshot's scale {} differs from the transforms.json's {}; using the snapshot's", source, s.scale,
             *cameras->ngp_scale);
  }

  FieldOptions fo;
  fo.flavor = "instant-ngp";
  fo.encoding.grid_rule = "instant-ngp";
  fo.encoding.levels = s.encoding.levels;
  fo.encoding.features = s.encoding.features;
  fo.encoding.log2_table_size = s.encoding.log2_table_size;
  fo.encoding.base_resolution = std::max(2, s.encoding.base_resolution);
  if (s.encoding.base_resolution < 2) ThrowInputError(source, "encoding.base_resolution", "at least 2");
  fo.encoding.per_level_scale = s.encoding.per_level_scale;
  fo.hidden_dim = dn.width;
  fo.geo_feature_dim = dn.padded_outputs - 1;
  fo.color_hidden_layers = rn.hidden_layers;
  fo.density_scale = frame.scale;
  fo.axis_order = {frame.axis_order[0], frame.axis_order[1], frame.axis_order[2]};
  fo.aabb_min.assign(3, 0);
  fo.aabb_max.assign(3, 0);
  for (int k = 0; k < 3; ++k) {  // block axis j = axis_order[k] carries ngp axis k
    const int j = frame.axis_order[k];
    fo.aabb_min[j] = (s.aabb_min[k] - frame.offset[j]) / frame.scale;
    fo.aabb_max[j] = (s.aabb_max[k] - frame.offset[j]) / frame.scale;
  }
  OccupancyGridOptions go;
  go.resolution = s.density_grid_size >= 4 ? s.density_grid_size : 128;
  MarchOptions march;
  double side = 0;
  for (int k = 0; k < 3; ++k) side = std::max(side, fo.aabb_max[k] - fo.aabb_min[k]);
  march.step_size = side * std::sqrt(3.0) / options.steps_per_aabb;
  march.near = 0.0;
  NerfBlock block = NerfBlock::Create(fo, go, march, 0);

  torch::NoGradGuard no_grad;
  // Hash table: level l's rows fill the first `entries` rows of its [T, F] slice; the rest stay 0.
  const auto levels = NgpGridLevels(s.encoding);
  block.field->table.zero_();
  const int F = s.encoding.features;
  for (int l = 0; l < s.encoding.levels; ++l) {
    const auto src = torch::from_blob(const_cast<float*>(s.params.data() + s.grid_params_offset + levels[l].offset * F),
                                      {std::int64_t(levels[l].entries), F}, torch::kFloat32);
    block.field->table[l].slice(0, 0, levels[l].entries).copy_(src);
  }
  // MLPs: matrices in file order; the first density matrix drops the grid's zero padding columns,
  // the last colour matrix keeps its 3 used rows.
  auto params = block.field->named_parameters();
  std::int64_t off = s.density_params_offset;
  CopyMatrix(s.params, off, dn.inputs, params["density_mlp.0.weight"]);
  off += std::int64_t(dn.width) * dn.inputs;
  CopyMatrix(s.params, off, dn.width, params["density_mlp.2.weight"]);
  off = s.rgb_params_offset;
  for (int m = 0; m <= rn.hidden_layers; ++m) {
    const int cols = m == 0 ? rn.inputs : rn.width;
    CopyMatrix(s.params, off, cols, params["color_mlp." + std::to_string(2 * m) + ".weight"]);
    off += std::int64_t(m == rn.hidden_layers ? rn.padded_outputs : rn.width) * cols;
  }

  if (s.density_cascades > 0 && s.density_grid_size >= 4) ImportOccupancy(s, frame, options, block.grid.get());
  block.train_options = {{"imported_from", "instant-ngp"},
                         {"source", source},
                         {"frame", options.frame},
                         {"ngp_scale", frame.scale},
                         {"ngp_offset", frame.offset}};

  if (cameras) {
    block.cameras = *cameras;
    block.cameras.aabb_min = Eigen::Vector3d(fo.aabb_min[0], fo.aabb_min[1], fo.aabb_min[2]);
    block.cameras.aabb_max = Eigen::Vector3d(fo.aabb_max[0], fo.aabb_max[1], fo.aabb_max[2]);
    if (options.frame == "ngp") {
      // x_ngp = C (x + o) with s = 1... in general x_ngp = C (s x + o): cam_from_ngp = [R C^T | s t - R o].
      const NgpFrame nerf = ImportFrame(s, NgpImportOptions{}, cameras);
      Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
      for (int k = 0; k < 3; ++k) C(k, nerf.axis_order[k]) = 1;
      const Eigen::Vector3d o(nerf.offset[0], nerf.offset[1], nerf.offset[2]);
      for (auto& f : block.cameras.frames) {
        const Eigen::Matrix3d R = f.cam_from_world.rotation.toRotationMatrix();
        f.cam_from_world =
            Rigid3d(Eigen::Matrix3d(R * C.transpose()), nerf.scale * f.cam_from_world.translation - R * o);
        f.near *= nerf.scale;
        f.far *= nerf.scale;
      }
    }
  }
  return block;
}

}  // namespace nerfreg
