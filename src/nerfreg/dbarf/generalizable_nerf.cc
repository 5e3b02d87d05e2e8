#include "nerfreg/dbarf/generalizable_nerf.h"

#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/torch_archive.h"

namespace nerfreg {
namespace {

const char* kGeneralizableNerfFormatTag = "nerfreg-generalizable-nerf";

}  // namespace

GeneralizableNerfOptions GeneralizableNerfOptions::Paper() {
  return {ResUNetOptions::Paper(), IbrNetOptions::Paper(), IbrRenderOptions::Paper()};
}

GeneralizableNerfOptions GeneralizableNerfOptions::Cpu() {
  return {ResUNetOptions::Cpu(), IbrNetOptions::Cpu(), IbrRenderOptions::Cpu()};
}

bool GeneralizableNerfOptions::Check() const {
  if (!features.Check() || !ibrnet.Check() || !render.Check()) return false;
  if (features.nerf_channels != ibrnet.feature_channels) {
    LOG_ERROR("GeneralizableNerfOptions: features.nerf_channels ({}) != ibrnet.feature_channels ({})",
              features.nerf_channels, ibrnet.feature_channels);
    return false;
  }
  return true;
}

Json GeneralizableNerfOptionsToJson(const GeneralizableNerfOptions& o) {
  const auto& f = o.features;
  return {{"features",
           {{"in_channels", f.in_channels},
            {"stem_channels", f.stem_channels},
            {"layer_channels", f.layer_channels},
            {"layer_blocks", f.layer_blocks},
            {"out_channels", f.out_channels},
            {"nerf_channels", f.nerf_channels}}},
          {"ibrnet",
           {{"feature_channels", o.ibrnet.feature_channels},
            {"anti_alias_pooling", o.ibrnet.anti_alias_pooling},
            {"anti_alias_init", o.ibrnet.anti_alias_init},
            {"attention_heads", o.ibrnet.attention_heads}}},
          {"render",
           {{"num_samples", o.render.num_samples},
            {"valid_sample_fraction", o.render.valid_sample_fraction},
            {"chunk_rays", o.render.chunk_rays}}}};
}

GeneralizableNerfOptions GeneralizableNerfOptionsFromJson(const JsonField& j) {
  GeneralizableNerfOptions o;
  const JsonField f = j["features"];
  o.features.in_channels = f["in_channels"].Int();
  o.features.stem_channels = f["stem_channels"].Int();
  o.features.layer_channels = f["layer_channels"].Int64s();
  o.features.layer_blocks = f["layer_blocks"].Int64s();
  o.features.out_channels = f["out_channels"].Int();
  o.features.nerf_channels = f["nerf_channels"].Int();
  const JsonField n = j["ibrnet"];
  o.ibrnet.feature_channels = n["feature_channels"].Int();
  o.ibrnet.anti_alias_pooling = n["anti_alias_pooling"].Bool();
  o.ibrnet.anti_alias_init = n["anti_alias_init"].Double();
  o.ibrnet.attention_heads = n["attention_heads"].Int();
  const JsonField r = j["render"];
  o.render.num_samples = r["num_samples"].Int();
  o.render.valid_sample_fraction = r["valid_sample_fraction"].Double();
  o.render.chunk_rays = r["chunk_rays"].Int();
  if (!o.Check()) j.Fail("valid generalizable NeRF options (see the log)");
  return o;
}

GeneralizableNerf::GeneralizableNerf(const GeneralizableNerfOptions& opts) : options(opts) {
  TORCH_CHECK(options.Check(), "GeneralizableNerf: invalid options");
  feature_net = ResUNet(options.features);
  ibrnet = IbrNet(options.ibrnet);
}

IbrSourceViews GeneralizableNerf::PrepareSources(const torch::Tensor& images, const torch::Tensor& intrinsics,
                                                 const torch::Tensor& cam_from_world) {
  IbrSourceViews s{images, intrinsics, cam_from_world, feature_net->NerfFeatures(images)};
  s.CheckShapes();
  return s;
}

IbrRenderOutput GeneralizableNerf::RenderRays(const IbrSourceViews& sources, const IbrRays& rays, double near,
                                              double far, bool training) {
  return RenderIbrRays(ibrnet, sources, rays, near, far, options.render, training);
}

void SaveGeneralizableNerf(const GeneralizableNerf& model, const std::string& path) {
  const Json meta = {{"format", kGeneralizableNerfFormatTag},
                     {"version", kGeneralizableNerfCheckpointVersion},
                     {"options", GeneralizableNerfOptionsToJson(model.options)}};
  torch::serialize::OutputArchive archive, features, ibrnet;
  archive.write("meta", StringTensor(meta.dump()));
  model.feature_net->save(features);
  model.ibrnet->save(ibrnet);
  archive.write("feature_net", features);
  archive.write("ibrnet", ibrnet);
  SaveArchiveAtomic(archive, path);
}

double GeneralizableNerfParameterLowerBound(const GeneralizableNerfOptions& o) {
  const ResUNetOptions& f = o.features;
  double n = 49.0 * f.in_channels * f.stem_channels + double(f.out_channels) * f.out_channels;
  for (size_t l = 0; l < f.layer_channels.size() && l < f.layer_blocks.size(); ++l) {
    n += f.layer_blocks[l] * 9.0 * f.layer_channels[l] * f.layer_channels[l];
  }
  if (f.layer_channels.size() >= 3) {
    const double c0 = f.layer_channels[0], c1 = f.layer_channels[1], c2 = f.layer_channels[2];
    n += 9.0 * (c2 * c1 + 2 * c1 * c1 + c1 * c0 + 2 * c0 * f.out_channels);
  }
  return n + 208.0 * (3.0 + o.ibrnet.feature_channels);
}

GeneralizableNerf LoadGeneralizableNerf(const std::string& path, const GeneralizableNerfOptions* expected) {
  torch::serialize::InputArchive archive;
  const Json meta = LoadArchiveMeta(path, "generalizable NeRF checkpoint", kGeneralizableNerfFormatTag,
                                    kGeneralizableNerfCheckpointVersion, &archive);
  const JsonField m(meta, path);
  const GeneralizableNerfOptions options = GeneralizableNerfOptionsFromJson(m["options"]);
  if (expected != nullptr && GeneralizableNerfOptionsToJson(*expected) != GeneralizableNerfOptionsToJson(options)) {
    ThrowInputError(path, "options",
                    "the configuration " + GeneralizableNerfOptionsToJson(*expected).dump() +
                        " (the checkpoint has another configuration)");
  }
  CheckArchiveCanHold(path, "options", GeneralizableNerfParameterLowerBound(options));
  GeneralizableNerf model(options);
  try {
    torch::serialize::InputArchive features, ibrnet;
    archive.read("feature_net", features);
    archive.read("ibrnet", ibrnet);
    model.feature_net->load(features);
    model.ibrnet->load(ibrnet);
  } catch (const c10::Error&) {
    ThrowInputError(path, "", "a complete generalizable NeRF checkpoint (tensors missing or of the wrong shape)");
  }
  return model;
}

}  // namespace nerfreg
