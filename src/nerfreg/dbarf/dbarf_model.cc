#include "nerfreg/dbarf/dbarf_model.h"

#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/util/torch_archive.h"

namespace nerfreg {
namespace {

const char* kDbarfFormatTag = "nerfreg-dbarf-weights";

// A lower bound on the pose network's parameters (pose_depth_net.cc): the 3x3 residual blocks of
// its three encoders and the six 1x5 / 5x1 convolutions of each of its two GRUs. With the
// generalizable NeRF's bound, what a weights file must be able to hold before anything is built.
double PoseDepthNetParameterLowerBound(const PoseDepthNetOptions& o) {
  double n = 0;
  for (const int64_t w : o.encoder_widths) n += 3.0 * o.blocks_per_stage * 2 * 9.0 * double(w) * w;
  const double hid = o.hidden_channels, in = o.context_channels + o.motion_channels;
  return n + 2.0 * 6 * 5 * hid * (hid + in) + 9.0 * o.head_channels * o.hidden_channels;
}

}  // namespace

DbarfOptions DbarfOptions::Paper() { return {GeneralizableNerfOptions::Paper(), PoseDepthNetOptions::Paper()}; }
DbarfOptions DbarfOptions::Cpu() { return {GeneralizableNerfOptions::Cpu(), PoseDepthNetOptions::Cpu()}; }

DbarfOptions DbarfOptions::Named(const std::string& name) {
  if (name == "paper") return Paper();
  if (name == "cpu") return Cpu();
  throw InputError("--config: expected \"paper\" or \"cpu\", got \"" + name + "\"");
}

bool DbarfOptions::Check() const { return nerf.Check() && pose.Check(); }

Json PoseDepthNetOptionsToJson(const PoseDepthNetOptions& o) {
  return {{"encoder_widths", o.encoder_widths},     {"blocks_per_stage", o.blocks_per_stage},
          {"fuse_channels", o.fuse_channels},       {"feature_channels", o.feature_channels},
          {"hidden_channels", o.hidden_channels},   {"context_channels", o.context_channels},
          {"motion_channels", o.motion_channels},   {"state_channels", o.state_channels},
          {"head_channels", o.head_channels},       {"mask_channels", o.mask_channels},
          {"outer_iterations", o.outer_iterations}, {"inner_iterations", o.inner_iterations},
          {"rotation_scale", o.rotation_scale},     {"batch_statistics", o.batch_statistics}};
}

PoseDepthNetOptions PoseDepthNetOptionsFromJson(const JsonField& j) {
  PoseDepthNetOptions o;
  o.encoder_widths = j["encoder_widths"].Int64s();
  o.blocks_per_stage = j["blocks_per_stage"].Int();
  o.fuse_channels = j["fuse_channels"].Int();
  o.feature_channels = j["feature_channels"].Int();
  o.hidden_channels = j["hidden_channels"].Int();
  o.context_channels = j["context_channels"].Int();
  o.motion_channels = j["motion_channels"].Int();
  o.state_channels = j["state_channels"].Int();
  o.head_channels = j["head_channels"].Int();
  o.mask_channels = j["mask_channels"].Int();
  o.outer_iterations = j["outer_iterations"].Int();
  o.inner_iterations = j["inner_iterations"].Int();
  o.rotation_scale = j["rotation_scale"].Double();
  // Files written before the option normalised with running statistics in inference; they are
  // read with the default, batch statistics (what they were trained with).
  o.batch_statistics = j.Has("batch_statistics") ? j["batch_statistics"].Bool() : true;
  if (!o.Check()) j.Fail("valid pose/depth network options (see the log)");
  return o;
}

Json DbarfOptionsToJson(const DbarfOptions& o) {
  return {{"nerf", GeneralizableNerfOptionsToJson(o.nerf)}, {"pose", PoseDepthNetOptionsToJson(o.pose)}};
}

DbarfOptions DbarfOptionsFromJson(const JsonField& j) {
  return {GeneralizableNerfOptionsFromJson(j["nerf"]), PoseDepthNetOptionsFromJson(j["pose"])};
}

DbarfModel::DbarfModel(const DbarfOptions& opts) : options(opts), nerf(opts.nerf) {
  TORCH_CHECK(options.Check(), "DbarfModel: invalid options");
  pose_net = PoseDepthNet(options.pose);
}

std::vector<torch::Tensor> DbarfModel::NerfParameters() const {
  std::vector<torch::Tensor> p = nerf.FeatureParameters();
  for (const auto& t : nerf.MlpParameters()) p.push_back(t);
  return p;
}

void DbarfModel::Train(bool on) {
  nerf.feature_net->train(on);
  nerf.ibrnet->train(on);
  pose_net->train(on);
}

void DbarfModel::To(torch::Device device) {
  nerf.feature_net->to(device);
  nerf.ibrnet->to(device);
  pose_net->to(device);
}

void SaveDbarfWeights(const DbarfModel& model, const std::string& path) {
  const Json meta = {{"format", kDbarfFormatTag},
                     {"version", kDbarfWeightsVersion},
                     {"options", DbarfOptionsToJson(model.options)},
                     {"training", model.training}};
  torch::serialize::OutputArchive archive, features, ibrnet, pose;
  archive.write("meta", StringTensor(meta.dump()));
  model.nerf.feature_net->save(features);
  model.nerf.ibrnet->save(ibrnet);
  model.pose_net->save(pose);
  archive.write("feature_net", features);
  archive.write("ibrnet", ibrnet);
  archive.write("pose_net", pose);
  SaveArchiveAtomic(archive, path);
}

DbarfModel LoadDbarfWeights(const std::string& path, const DbarfOptions* expected) {
  torch::serialize::InputArchive archive;
  const Json meta = LoadArchiveMeta(path, "DBARF weights file", kDbarfFormatTag, kDbarfWeightsVersion, &archive);
  const JsonField m(meta, path);
  const DbarfOptions options = DbarfOptionsFromJson(m["options"]);
  if (expected != nullptr && DbarfOptionsToJson(*expected) != DbarfOptionsToJson(options)) {
    ThrowInputError(
        path, "options",
        "the configuration " + DbarfOptionsToJson(*expected).dump() + " (the weights are of another configuration)");
  }
  CheckArchiveCanHold(
      path, "options",
      GeneralizableNerfParameterLowerBound(options.nerf) + PoseDepthNetParameterLowerBound(options.pose));
  DbarfModel model(options);
  if (meta.contains("training") && meta["training"].is_object()) model.training = meta["training"];
  try {
    torch::serialize::InputArchive features, ibrnet, pose;
    archive.read("feature_net", features);
    archive.read("ibrnet", ibrnet);
    archive.read("pose_net", pose);
    model.nerf.feature_net->load(features);
    model.nerf.ibrnet->load(ibrnet);
    model.pose_net->load(pose);
  } catch (const c10::Error&) {
    ThrowInputError(path, "", "complete DBARF weights (tensors missing or of the wrong shape)");
  }
  return model;
}

}  // namespace nerfreg
