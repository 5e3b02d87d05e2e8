#include "nerfreg/dbarf/generalizable_nerf.h"

#include <gtest/gtest.h>

#include <fstream>

#include "nerfreg/util/file_util.h"
#include "nerfreg/util/test_util.h"

namespace nerfreg {
namespace {

TEST(GeneralizableNerf, OptionsRoundTripThroughJsonAndCheck) {
  for (const auto& o : {GeneralizableNerfOptions::Paper(), GeneralizableNerfOptions::Cpu()}) {
    const Json j = GeneralizableNerfOptionsToJson(o);
    EXPECT_EQ(GeneralizableNerfOptionsToJson(GeneralizableNerfOptionsFromJson(JsonField(j, "opts.json"))), j);
  }
  GeneralizableNerfOptions bad = GeneralizableNerfOptions::Cpu();
  bad.ibrnet.feature_channels = 32;  // the ResUNet gives 16
  EXPECT_FALSE(bad.Check());
  Json j = GeneralizableNerfOptionsToJson(GeneralizableNerfOptions::Cpu());
  j["render"]["num_samples"] = 1;
  EXPECT_NE(InputErrorOf([&] { GeneralizableNerfOptionsFromJson(JsonField(j, "opts.json")); }), "");
}

TEST(GeneralizableNerf, SaveLoadRoundTripRendersTheSame) {
  ScopedTempDir dir;
  torch::manual_seed(11);
  GeneralizableNerf model(GeneralizableNerfOptions::Cpu());
  {
    torch::NoGradGuard no_grad;
    model.ibrnet->s.fill_(0.7);  // a trained value, not the initial one
  }
  const std::string path = dir.File("sub/model.pt");
  SaveGeneralizableNerf(model, path);
  const GeneralizableNerfOptions expected = GeneralizableNerfOptions::Cpu();
  GeneralizableNerf loaded = LoadGeneralizableNerf(path, &expected);
  EXPECT_FLOAT_EQ(loaded.ibrnet->s.item<float>(), 0.7f);

  torch::NoGradGuard no_grad;
  const torch::Tensor images = torch::rand({2, 3, 24, 32});
  const torch::Tensor k = torch::tensor({30.0, 0.0, 16.0, 0.0, 30.0, 12.0, 0.0, 0.0, 1.0}, torch::kFloat).view({3, 3});
  torch::Tensor poses = torch::eye(4).repeat({2, 1, 1});
  poses[0][0][3] = 0.2;
  poses[1][0][3] = -0.2;
  const IbrRays rays = TargetRays(k, torch::eye(4), 24, 32, torch::arange(0, 768, 37));
  const IbrRenderOutput a =
      model.RenderRays(model.PrepareSources(images, k.expand({2, 3, 3}), poses), rays, 1, 5, false);
  const IbrRenderOutput b =
      loaded.RenderRays(loaded.PrepareSources(images, k.expand({2, 3, 3}), poses), rays, 1, 5, false);
  EXPECT_TRUE(torch::equal(a.rgb, b.rgb));
  EXPECT_TRUE(torch::equal(a.depth, b.depth));
  EXPECT_EQ(model.FeatureParameters().size() + model.MlpParameters().size(),
            loaded.FeatureParameters().size() + loaded.MlpParameters().size());
}

TEST(GeneralizableNerf, LoadRejectsForeignTruncatedAndOtherConfigurations) {
  ScopedTempDir dir;
  GeneralizableNerf model(GeneralizableNerfOptions::Cpu());
  const std::string path = dir.File("model.pt");
  SaveGeneralizableNerf(model, path);

  EXPECT_NE(InputErrorOf([&] { LoadGeneralizableNerf(dir.File("missing.pt")); }), "");
  // Another configuration than the expected one.
  GeneralizableNerfOptions other = GeneralizableNerfOptions::Cpu();
  other.render.num_samples = 48;
  const std::string wrong = InputErrorOf([&] { LoadGeneralizableNerf(path, &other); });
  EXPECT_NE(wrong.find("another configuration"), std::string::npos) << wrong;
  // Truncated.
  const std::string bytes = ReadFileToString(path);
  WriteFileAtomic(dir.File("truncated.pt"), bytes.substr(0, bytes.size() / 2));
  EXPECT_NE(InputErrorOf([&] { LoadGeneralizableNerf(dir.File("truncated.pt")); }), "");
  // Foreign: a torch archive without our meta, and one with another format tag.
  torch::serialize::OutputArchive foreign;
  foreign.write("weights", torch::zeros({3}));
  foreign.save_to(dir.File("foreign.pt"));
  EXPECT_NE(InputErrorOf([&] { LoadGeneralizableNerf(dir.File("foreign.pt")); }), "");
  torch::serialize::OutputArchive tagged;
  const std::string meta = R"({"format": "nerfreg-nerf-block", "version": 1})";
  tagged.write("meta", torch::from_blob(const_cast<char*>(meta.data()), {int64_t(meta.size())}, torch::kUInt8).clone());
  tagged.save_to(dir.File("tagged.pt"));
  const std::string tag_error = InputErrorOf([&] { LoadGeneralizableNerf(dir.File("tagged.pt")); });
  EXPECT_NE(tag_error.find("format"), std::string::npos) << tag_error;
  // Not a file torch can read at all.
  WriteFileAtomic(dir.File("text.pt"), "hello");
  EXPECT_NE(InputErrorOf([&] { LoadGeneralizableNerf(dir.File("text.pt")); }), "");
}

// Found by fuzz/torch_archive_fuzz.cc: a checkpoint whose options claim a 100000-channel ResUNet
// layer built ~360 GB of convolutions before the tensors were read. Refused from the file size.
TEST(GeneralizableNerf, StoredSizesTheFileCannotHoldAreInputErrors) {
  ScopedTempDir dir;
  GeneralizableNerf model(GeneralizableNerfOptions::Cpu());
  model.options.features.layer_channels = {16, 32, 100000};
  const std::string path = dir.File("huge.pt");
  SaveGeneralizableNerf(model, path);  // the CPU network's tensors under the huge options
  const std::string e = InputErrorOf([&] { LoadGeneralizableNerf(path); });
  EXPECT_EQ(e.rfind(path + ": options:", 0), 0u) << e;
  EXPECT_NE(e.find("parameters"), std::string::npos) << e;
}

}  // namespace
}  // namespace nerfreg
