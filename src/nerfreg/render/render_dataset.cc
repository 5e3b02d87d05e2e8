#include "nerfreg/render/render_dataset.h"

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <random>

#include "nerfreg/data/npy.h"
#include "nerfreg/data/transforms_json.h"
#include "nerfreg/geometry/conventions.h"
#include "nerfreg/render/raycaster.h"
#include "nerfreg/render/trajectory.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/progress.h"
#include "nerfreg/util/timer.h"

namespace fs = std::filesystem;

namespace nerfreg {

void RenderDatasetOptions::Check() const {
  if (trajectory != "orbit" && trajectory != "forward" && trajectory != "llff" && trajectory != "room")
    ThrowInputError("--trajectory", "", "orbit, forward, llff or room, got " + trajectory);
  if (views < 0 || views > 100000) ThrowInputError("--views", "", "a count in 1..100000");
  if (width < 0 || height < 0 || width > 8192 || height > 8192) ThrowInputError("--size", "", "W[xH] in 1..8192");
  if (blocks < 1 || blocks > 64) ThrowInputError("--blocks", "", "1..64");
  if (test_every < 0) ThrowInputError("--test-every", "", ">= 0");
  if (!(forward_spread >= 0 && forward_spread <= 3)) ThrowInputError("--spread", "", "0..3 (0: the default)");
  if (!(std::abs(k1) < 1) || !(std::abs(k2) < 1)) ThrowInputError("--distortion", "", "K1[,K2] each in (-1, 1)");
  if (!(noise_sigma >= 0 && noise_sigma < 1)) ThrowInputError("--noise", "", "a standard deviation in [0, 1)");
  if (jpeg_quality < 0 || jpeg_quality > 100) ThrowInputError("--jpeg", "", "a quality in 1..100 (0: PNG)");
  if (write_splats) splats.Check();
  try {
    block_frame.Check();
    render.Check();
  } catch (const std::invalid_argument& e) {
    throw InputError(std::string("render options: ") + e.what());
  }
}

Json RenderDatasetOptions::ToJson() const {
  return {{"trajectory", trajectory},
          {"views", views},
          {"width", width},
          {"height", height},
          {"blocks", blocks},
          {"test_every", test_every},
          {"seed", seed},
          {"forward_spread", forward_spread},
          {"trajectory_seed", trajectory_seed},
          {"block_max_rotation_deg", block_frame.max_rotation_deg},
          {"block_max_translation", block_frame.max_translation},
          {"block_min_scale", block_frame.min_scale},
          {"block_max_scale", block_frame.max_scale},
          {"supersample", render.supersample},
          {"write_depth", write_depth},
          {"k1", k1},
          {"k2", k2},
          {"noise_sigma", noise_sigma},
          {"jpeg_quality", jpeg_quality},
          {"write_splats", write_splats},
          {"splat_voxel", splats.voxel}};
}

RenderDatasetSummary RenderDataset(const TriangleMesh& mesh, const RenderDatasetOptions& options,
                                   const std::string& out_dir) {
  options.Check();
  mesh.Check("mesh");
  Timer timer;
  const bool orbit = options.trajectory == "orbit";
  std::vector<PosedCamera> cams;
  if (orbit) {
    OrbitOptions o;
    if (options.views) o.num_views = options.views;
    o.width = options.width ? options.width : 100;
    o.height = options.height ? options.height : o.width;
    cams = OrbitTrajectory(o);
  } else {
    // Scenes: 128x96 by default, the height 3/4 of a given width.
    const auto set_size = [&](int* width, int* height) {
      if (options.width) *width = options.width;
      if (options.height)
        *height = options.height;
      else if (options.width)
        *height = options.width * 3 / 4;
    };
    if (options.trajectory == "llff") {
      HandheldOptions o;
      if (options.views) o.num_views = options.views;
      if (options.forward_spread > 0) o.spread = options.forward_spread;
      o.seed = options.trajectory_seed;
      set_size(&o.width, &o.height);
      cams = HandheldTrajectory(o);
    } else if (options.trajectory == "room") {
      RoomWalkOptions o;
      if (options.views) o.num_views = options.views;
      o.seed = options.trajectory_seed;
      set_size(&o.width, &o.height);
      cams = RoomWalkTrajectory(o);
    } else {
      ForwardOptions o;
      if (options.views) o.num_views = options.views;
      if (options.forward_spread > 0) o.spread = options.forward_spread;
      set_size(&o.width, &o.height);
      cams = ForwardTrajectory(o);
    }
  }
  for (PosedCamera& c : cams) c.camera.k1 = options.k1, c.camera.k2 = options.k2;
  const int n = static_cast<int>(cams.size());
  if (options.blocks > n) ThrowInputError("--blocks", "", "at most the number of views (" + std::to_string(n) + ")");

  OutputDir output(out_dir, options.force);
  const std::string& tmp = output.tmp();
  {
    RayCaster caster(mesh);
    SurfaceSplatter splatter(caster, options.splats);
    Dataset world;
    world.root = tmp;
    ProgressBar bar("render", n, "view");
    std::mt19937 noise_rng(options.seed * 104729u + 17u);
    std::normal_distribution<float> noise(0.f, static_cast<float>(options.noise_sigma));
    // Noise on the colour channels (not alpha), then the file format's quantisation.
    const auto degrade = [&](Image im) {
      if (options.noise_sigma > 0)
        for (size_t p = 0; p < im.data.size(); ++p)
          if (im.channels != 4 || p % 4 != 3) im.data[p] += noise(noise_rng);
      return im;
    };
    for (int i = 0; i < n; ++i) {
      char name[32];
      std::snprintf(name, sizeof(name), options.jpeg_quality > 0 ? "r_%03d.jpg" : "r_%03d.png", i);
      const RenderResult r = RenderView(caster, mesh, cams[i].camera, cams[i].cam_from_world, options.render);
      if (options.write_splats) splatter.AddView(i, cams[i].camera, cams[i].cam_from_world, r.rgba);
      Frame f;
      f.name = name;
      f.file_path = std::string("images/") + name;
      f.camera = cams[i].camera;
      f.cam_from_world = cams[i].cam_from_world;
      if (orbit) {
        WriteImage(world.ImagePath(f), degrade(r.rgba), options.jpeg_quality);
      } else {
        WriteImage(world.ImagePath(f), degrade(CompositeOver(r.rgba, 0, 0, 0)), options.jpeg_quality);
        // Depth bounds of what this view sees, padded (LLFF's near/far).
        float lo = INFINITY, hi = 0;
        for (float d : r.depth.data)
          if (d > 0) {
            lo = std::min(lo, d);
            hi = std::max(hi, d);
          }
        f.near = std::isfinite(lo) ? 0.9 * lo : 0.1;
        f.far = hi > 0 ? 1.1 * hi : 100.0;
      }
      if (options.write_depth) {
        NpyArray d;
        d.shape = {r.depth.height, r.depth.width};
        d.data.assign(r.depth.data.begin(), r.depth.data.end());
        WriteNpy(JoinPaths(tmp, std::string("depth/") + fs::path(name).stem().string() + ".npy"), d);
      }
      world.frames.push_back(f);
      bar.Tick();
    }
    bar.Finish();

    // Blocks: k-means on camera centres; every n-th image of a block is a test view.
    std::vector<int> label(n, 0);
    if (options.blocks >= 2) {
      std::vector<Eigen::Vector3d> centres;
      for (const auto& c : cams) centres.push_back(CameraCenter(c.cam_from_world));
      label = KMeans(centres, options.blocks, options.seed);
    }
    std::vector<int> index_in_block(options.blocks, 0);
    for (int i = 0; i < n; ++i) {
      const int j = index_in_block[label[i]]++;
      world.frames[i].split = options.test_every > 0 && j % options.test_every == 0 ? "test" : "train";
    }
    Eigen::Vector3f mn, mx;
    mesh.Bounds(&mn, &mx);
    world.aabb_min = mn.cast<double>();
    world.aabb_max = mx.cast<double>();
    WriteTransformsJson(world, JoinPaths(tmp, "transforms.json"));
    if (options.write_splats) WriteSplatPly(splatter.Build({}), JoinPaths(tmp, "splats.ply"));

    if (options.blocks >= 2) {
      std::mt19937 rng(options.seed * 7919u + 1u);
      Json gt_blocks = Json::array();
      for (int k = 0; k < options.blocks; ++k) {
        const Sim3d block_from_world = RandomBlockFrame(options.block_frame, rng);
        const std::string block_dir = JoinPaths(tmp, "block_" + std::to_string(k));
        Dataset block;
        block.root = block_dir;
        Json names = Json::array();
        for (int i = 0; i < n; ++i) {
          if (label[i] != k) continue;
          Frame f = world.frames[i];
          f.cam_from_world = block_from_world.TransformCamera(f.cam_from_world);
          f.near *= block_from_world.scale;
          f.far *= block_from_world.scale;
          CreateDirectories(JoinPaths(block_dir, "images"));
          fs::copy_file(world.ImagePath(world.frames[i]), block.ImagePath(f));
          names.push_back(f.name);
          block.frames.push_back(f);
        }
        // The object's box in the block frame (for the block's NeRF bounds).
        Eigen::Vector3d bmn = Eigen::Vector3d::Constant(INFINITY), bmx = -bmn;
        for (const auto& v : mesh.vertices) {
          const Eigen::Vector3d p = block_from_world * v.cast<double>();
          bmn = bmn.cwiseMin(p);
          bmx = bmx.cwiseMax(p);
        }
        block.aabb_min = bmn;
        block.aabb_max = bmx;
        WriteTransformsJson(block, JoinPaths(block_dir, "transforms.json"));
        if (options.write_splats) {
          std::vector<int> views;
          for (int i = 0; i < n; ++i)
            if (label[i] == k) views.push_back(i);
          WriteSplatPly(splatter.Build(views, block_from_world), JoinPaths(block_dir, "splats.ply"));
        }
        gt_blocks.push_back({{"block_from_world", MatrixToJson(block_from_world.ToMatrix())},
                             {"scale", block_from_world.scale},
                             {"frames", names}});
      }
      WriteJsonFile(JoinPaths(tmp, "ground_truth.json"), {{"blocks", gt_blocks}});
    }
    WriteJsonFile(JoinPaths(tmp, "render_options.json"), options.ToJson());

    output.Commit();
  }
  RenderDatasetSummary s;
  s.views = n;
  s.blocks = options.blocks;
  s.seconds = timer.Seconds();
  return s;
}

}  // namespace nerfreg
