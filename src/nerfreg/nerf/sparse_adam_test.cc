#include "nerfreg/nerf/sparse_adam.h"

#include <gtest/gtest.h>

namespace nerfreg {
namespace {

TEST(SparseAdam, MatchesTorchAdamOnTouchedEntriesAndSkipsTheRest) {
  torch::manual_seed(6);
  auto a = torch::randn({4, 64, 2}).requires_grad_(true);
  auto b = a.detach().clone().requires_grad_(true);
  SparseAdam sparse(a, SparseAdamOptions{0.9, 0.999, 1e-15});
  torch::optim::Adam dense({b}, torch::optim::AdamOptions(1e-2).eps(1e-15));
  const auto touched = torch::rand({4, 64, 2}) < 0.5;  // the same entries every step
  for (int step = 0; step < 5; ++step) {
    const auto g = torch::randn({4, 64, 2}) * touched;
    a.mutable_grad() = g.clone();
    b.mutable_grad() = g.clone();
    sparse.Step(1e-2);
    dense.step();
  }
  // Entries touched at every step follow torch Adam exactly; untouched ones never move (torch
  // Adam moves nothing either here: their moments stay zero).
  EXPECT_LT((a - b).abs().max().item<float>(), 1e-5);
  const auto before = a.detach().clone();
  a.mutable_grad() = torch::zeros_like(a);
  sparse.Step(1e-2);
  EXPECT_TRUE(torch::equal(a.detach(), before));  // a zero gradient is "not touched"
  // State round trip.
  torch::serialize::OutputArchive out;
  sparse.Save(out, "t");
  std::stringstream ss;
  out.save_to(ss);
  torch::serialize::InputArchive in;
  in.load_from(ss);
  SparseAdam copy(a, SparseAdamOptions{});
  copy.Load(in, "t");
}

}  // namespace
}  // namespace nerfreg
