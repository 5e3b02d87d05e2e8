#include "nerfreg/nerf/ngp_import.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "nerfreg/data/ngp_test_snapshot.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

// An independent plain-loop evaluation of instant-ngp's NeRF model from the documented formulas
// (tiny-cuda-nn grid + FullyFusedMLP layouts, NerfNetwork wiring), at a point x and direction d
// of the transforms.json frame. Returns {sigma per transforms.json length, r, g, b}.
std::array<double, 4> ReferenceNgp(const TestNgpSnapshot& t, const TestNgpSnapshotOptions& o, const double x[3],
                                   const double d[3]) {
  const double s = o.dataset_scale;
  const double v[3] = {s * x[0] + o.dataset_offset[0], s * x[1] + o.dataset_offset[1], s * x[2] + o.dataset_offset[2]};
  const double p[3] = {v[1], v[2], v[0]};  // nerf_matrix_to_ngp cycles xyz <- yzx
  const double dn[3] = {d[1], d[2], d[0]};
  const double lo = 0.5 - 0.5 * o.aabb_scale, size = o.aabb_scale;
  const int F = o.features, w = o.width, E = o.levels * o.features;
  const std::int64_t T = std::int64_t(1) << o.log2_table_size;
  const std::int64_t grid_off = std::int64_t(w) * E + 16 * w + w * 32 + w * w + 16 * w;
  std::vector<double> enc(E, 0.0);
  std::int64_t level_off = 0;
  for (int l = 0; l < o.levels; ++l) {
    const float scale = std::exp2(l * std::log2(static_cast<float>(o.per_level_scale))) * o.base_resolution - 1.0f;
    const std::uint32_t res = static_cast<std::uint32_t>(std::ceil(scale)) + 1;
    const std::int64_t rows = std::min<std::int64_t>((std::int64_t(res) * res * res + 7) / 8 * 8, T);
    const bool dense = std::int64_t(res) * res * res <= rows;
    double pos[3], frac[3];
    std::uint32_t g[3];
    for (int k = 0; k < 3; ++k) {
      pos[k] = static_cast<float>((p[k] - lo) / size) * scale + 0.5f;
      g[k] = static_cast<std::uint32_t>(std::floor(pos[k]));
      frac[k] = pos[k] - g[k];
    }
    for (int c = 0; c < 8; ++c) {
      const std::uint32_t cx = g[0] + (c & 1), cy = g[1] + ((c >> 1) & 1), cz = g[2] + ((c >> 2) & 1);
      const std::uint32_t idx = dense ? (cx + cy * res + cz * res * res) % std::uint32_t(rows)
                                      : (cx ^ (cy * 2654435761u) ^ (cz * 805459861u)) % std::uint32_t(T);
      const double wgt =
          ((c & 1) ? frac[0] : 1 - frac[0]) * ((c & 2) ? frac[1] : 1 - frac[1]) * ((c & 4) ? frac[2] : 1 - frac[2]);
      for (int f = 0; f < F; ++f) enc[l * F + f] += wgt * t.params[grid_off + (level_off + idx) * F + f];
    }
    level_off += rows;
  }
  auto matvec = [&](std::int64_t off, int rows, int cols, const std::vector<double>& in, bool relu) {
    std::vector<double> out(rows, 0.0);
    for (int r = 0; r < rows; ++r) {
      for (int c = 0; c < cols; ++c) out[r] += t.params[off + std::int64_t(r) * cols + c] * in[c];
      if (relu) out[r] = std::max(out[r], 0.0);
    }
    return out;
  };
  const auto h = matvec(0, w, E, enc, true);
  const auto dens = matvec(std::int64_t(w) * E, 16, w, h, false);
  const auto sh = SphericalHarmonics16(torch::tensor({{dn[0], dn[1], dn[2]}}, torch::kFloat64));
  std::vector<double> rgb_in(dens);
  for (int k = 0; k < 16; ++k) rgb_in.push_back(sh[0][k].item<double>());
  std::int64_t off = std::int64_t(w) * E + 16 * w;
  auto r1 = matvec(off, w, 32, rgb_in, true);
  off += 32 * w;
  auto r2 = matvec(off, w, w, r1, true);
  off += w * w;
  const auto out = matvec(off, 16, w, r2, false);  // 16 padded rows, 3 used
  auto sig = [](double z) { return 1 / (1 + std::exp(-z)); };
  return {std::exp(dens[0]) * s, sig(out[0]), sig(out[1]), sig(out[2])};
}

NerfBlock Import(const TestNgpSnapshot& t, const NgpImportOptions& options = {}) {
  ScopedTempDir dir;
  WriteTestNgpSnapshot(t.json, dir.File("s.ingp"), true);
  return SnapshotToNerfBlock(ReadNgpSnapshot(dir.File("s.ingp")), "s.ingp", options);
}

TEST(NgpImport, FieldEqualsIndependentReferenceOfTheNgpModel) {
  const TestNgpSnapshotOptions o;
  const TestNgpSnapshot t = MakeTestNgpSnapshot(o);
  NerfBlock block = Import(t);
  // AABB: ngp's [-0.5, 1.5]^3 brought back to the transforms.json frame (axis k of ngp is block axis (k+1)%3).
  const double s = o.dataset_scale;
  for (int j = 0; j < 3; ++j) {
    EXPECT_NEAR(block.field_options.aabb_min[j], (-0.5 - o.dataset_offset[j]) / s, 1e-9);
    EXPECT_NEAR(block.field_options.aabb_max[j], (1.5 - o.dataset_offset[j]) / s, 1e-9);
  }
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0.01, 0.99), n(-1, 1);
  const int N = 200;
  std::vector<float> xs, ds;
  std::vector<std::array<double, 4>> want;
  for (int i = 0; i < N; ++i) {
    double x[3], d[3];
    for (int j = 0; j < 3; ++j)
      x[j] = block.field_options.aabb_min[j] +
             u(rng) * (block.field_options.aabb_max[j] - block.field_options.aabb_min[j]);
    double len = 0;
    for (int j = 0; j < 3; ++j) len += (d[j] = n(rng)) * d[j];
    for (int j = 0; j < 3; ++j) d[j] /= std::sqrt(len);
    want.push_back(ReferenceNgp(t, o, x, d));
    for (int j = 0; j < 3; ++j) xs.push_back(static_cast<float>(x[j])), ds.push_back(static_cast<float>(d[j]));
  }
  const auto X = torch::tensor(xs).view({N, 3}), D = torch::tensor(ds).view({N, 3});
  for (bool reference : {false, true}) {
    block.field->options();
    FieldOptions fo = block.field_options;
    fo.reference_kernels = reference;
    NerfField field(fo);
    torch::NoGradGuard no_grad;
    for (auto& p : field->named_parameters()) p.value().copy_(block.field->named_parameters()[p.key()]);
    auto [sigma, rgb] = field->Forward(X, D);
    double max_rel = 0, max_rgb = 0, spread = 0;
    for (int i = 0; i < N; ++i) {
      max_rel = std::max(max_rel, std::abs(sigma[i].item<double>() - want[i][0]) / want[i][0]);
      for (int c = 0; c < 3; ++c) max_rgb = std::max(max_rgb, std::abs(rgb[i][c].item<double>() - want[i][1 + c]));
      spread = std::max(spread, std::abs(want[i][1] - want[0][1]));
    }
    EXPECT_LT(max_rel, 1e-4) << "reference kernels " << reference;
    EXPECT_LT(max_rgb, 1e-5) << "reference kernels " << reference;
    EXPECT_GT(spread, 1e-3);  // the colours vary: the test would see a wrong layout
  }
}

TEST(NgpImport, OccupancyGridEqualsTheWrittenDensityGrid) {
  const TestNgpSnapshotOptions o;
  const TestNgpSnapshot t = MakeTestNgpSnapshot(o);
  const NerfBlock block = Import(t);
  const int g = o.grid_size;
  ASSERT_EQ(block.grid->resolution(), g);
  const auto centres = block.grid->CellCenters();
  const auto occupied = block.grid->occupied().reshape(-1);
  auto raw = [&](int c, int x, int y, int z) { return t.occupied[((std::size_t(c) * g + z) * g + y) * g + x] != 0; };
  int count = 0;
  for (std::int64_t i = 0; i < centres.size(0); ++i) {
    double v[3];
    for (int j = 0; j < 3; ++j) v[j] = o.dataset_scale * centres[i][j].item<double>() + o.dataset_offset[j];
    const double p[3] = {v[1], v[2], v[0]};
    int c1[3];
    for (int k = 0; k < 3; ++k) c1[k] = static_cast<int>(std::floor(((p[k] - 0.5) / 2 + 0.5) * g));
    bool want;
    const bool inner = c1[0] >= g / 4 && c1[0] < 3 * g / 4 && c1[1] >= g / 4 && c1[1] < 3 * g / 4 && c1[2] >= g / 4 &&
                       c1[2] < 3 * g / 4;
    if (!inner) {
      want = raw(1, c1[0], c1[1], c1[2]);
    } else {
      want = false;
      for (int c = 0; c < 8; ++c)
        want |= raw(0, 2 * (c1[0] - g / 4) + (c & 1), 2 * (c1[1] - g / 4) + ((c >> 1) & 1),
                    2 * (c1[2] - g / 4) + ((c >> 2) & 1));
    }
    ASSERT_EQ(occupied[i].item<bool>(), want) << i;
    count += want;
  }
  EXPECT_EQ(count, 8 + 1 + 18);  // the cascade-0 box (2^3 coarse cells), its lone cell, the cascade-1 box
}

TEST(NgpImport, CheckpointRoundTripKeepsTheFlavor) {
  const TestNgpSnapshot t = MakeTestNgpSnapshot();
  NerfBlock block = Import(t);
  ScopedTempDir dir;
  SaveNerfBlock(block, dir.File("b.ckpt"));
  NerfBlock back = LoadNerfBlock(dir.File("b.ckpt"));
  EXPECT_EQ(back.field_options.flavor, "instant-ngp");
  EXPECT_EQ(back.field_options.encoding.grid_rule, "instant-ngp");
  EXPECT_EQ(back.field_options.axis_order, (std::vector<int>{1, 2, 0}));
  const auto x = torch::rand({50, 3}) * 2 - 1, d = torch::nn::functional::normalize(torch::randn({50, 3}));
  torch::NoGradGuard no_grad;
  const auto a = block.field->Forward(x, d), b = back.field->Forward(x, d);
  EXPECT_TRUE(torch::equal(a.first, b.first));
  EXPECT_TRUE(torch::equal(a.second, b.second));
  EXPECT_TRUE(torch::equal(block.grid->occupied(), back.grid->occupied()));
}

TEST(NgpImport, NgpFrameIsTheSameFieldInInstantNgpUnits) {
  const TestNgpSnapshotOptions o;
  const TestNgpSnapshot t = MakeTestNgpSnapshot(o);
  NgpImportOptions ngp;
  ngp.frame = "ngp";
  NerfBlock a = Import(t), b = Import(t, ngp);
  EXPECT_EQ(b.field_options.aabb_min, (std::vector<double>{-0.5, -0.5, -0.5}));
  const auto x = torch::rand({40, 3}) * 3 - 1.5, d = torch::nn::functional::normalize(torch::randn({40, 3}));
  const auto off = torch::tensor({o.dataset_offset[0], o.dataset_offset[1], o.dataset_offset[2]}, torch::kFloat32);
  const auto perm = torch::tensor({1, 2, 0}, torch::kInt64);
  const auto x_ngp = (x * o.dataset_scale + off).index_select(1, perm), d_ngp = d.index_select(1, perm);
  torch::NoGradGuard no_grad;
  const auto fa = a.field->Forward(x, d), fb = b.field->Forward(x_ngp, d_ngp);
  EXPECT_LT((fa.first - fb.first * o.dataset_scale).abs().max().item<float>(),
            1e-3 * fa.first.abs().max().item<float>() + 1e-6);
  EXPECT_LT((fa.second - fb.second).abs().max().item<float>(), 1e-5);
  EXPECT_EQ(a.grid->occupied().sum().item<int>(), b.grid->occupied().sum().item<int>());
}

TEST(NgpImport, UnsupportedLayoutsAreInputErrors) {
  TestNgpSnapshotOptions o;
  TestNgpSnapshot t = MakeTestNgpSnapshot(o);
  t.json["network"]["n_hidden_layers"] = 2;  // the file's n_params no longer matches either
  ScopedTempDir dir;
  WriteTestNgpSnapshot(t.json, dir.File("s.msgpack"), false);
  EXPECT_NE(InputErrorOf([&] { ReadNgpSnapshot(dir.File("s.msgpack")); }).find("snapshot.n_params"), std::string::npos);
}

}  // namespace
}  // namespace nerfreg
