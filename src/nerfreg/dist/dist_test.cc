#include "nerfreg/dist/dist.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <functional>

#include "nerfreg/dist/launch.h"
#include "nerfreg/util/error.h"  // InputError

extern char** environ;

namespace nerfreg {
namespace {

TEST(DistOptions, CheckNamesTheOption) {
  DistOptions o;
  EXPECT_NO_THROW(o.Check());
  o.nproc = 0;
  EXPECT_THROW(o.Check(), InputError);
  o = DistOptions();
  o.nnodes = 2;
  o.node_rank = 2;
  try {
    o.Check();
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--node-rank"), std::string::npos);
  }
  o.node_rank = 1;
  EXPECT_THROW(o.Check(), InputError);  // several machines need a --master-port they all know
  o.master_port = 29500;
  EXPECT_NO_THROW(o.Check());
}

TEST(DistOptions, WorkerEnvironmentFollowsTorchrun) {
  DistOptions o;
  o.nproc = 2;
  o.nnodes = 3;
  o.node_rank = 1;
  o.master_addr = "10.0.0.1";
  const auto env = WorkerEnvironment(o, 1, 29501, 8, false);
  auto get = [&](const std::string& k) {
    for (const auto& [key, v] : env) {
      if (key == k) return v;
    }
    return std::string("unset");
  };
  EXPECT_EQ(get("RANK"), "3");
  EXPECT_EQ(get("WORLD_SIZE"), "6");
  EXPECT_EQ(get("LOCAL_RANK"), "1");
  EXPECT_EQ(get("MASTER_ADDR"), "10.0.0.1");
  EXPECT_EQ(get("MASTER_PORT"), "29501");
  EXPECT_EQ(get("OMP_NUM_THREADS"), "4");  // 8 cores / 2 workers
  const auto user_threads = WorkerEnvironment(o, 0, 29501, 8, true);
  for (const auto& [k, v] : user_threads) EXPECT_NE(k, "OMP_NUM_THREADS");  // the user's setting stays
}

// Runs `body(group)` as rank 0 here and rank 1 in a forked child; returns the child's exit code.
int RunTwoRanks(const std::function<void(DistGroup&)>& body, const std::function<void(DistGroup&)>& child_body) {
  const int port = 20000 + getpid() % 20000;
  DistEnv env;
  env.world_size = 2;
  env.master_port = port;
  const pid_t pid = fork();
  if (pid == 0) {
    int code = 0;
    try {
      env.rank = 1;
      auto group = DistGroup::Join(env, 10);
      child_body(*group);
      code = ::testing::Test::HasFailure() ? 1 : 0;
    } catch (...) {
      code = 3;
    }
    _exit(code);
  }
  env.rank = 0;
  auto group = DistGroup::Join(env, 10);
  body(*group);
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

TEST(DistGroup, SingleProcessIsANoOp) {
  DistGroup single;
  std::vector<torch::Tensor> t = {torch::ones({3})};
  single.AllReduceSum(t);
  EXPECT_TRUE(torch::equal(t[0], torch::ones({3})));
  EXPECT_EQ(single.world_size(), 1);
  EXPECT_TRUE(single.is_main());
}

TEST(DistGroup, TwoProcessesSumGradientsAndBroadcastParameters) {
  // Rank r: parameter a = r + 1 everywhere, gradient of a = r + 1; b has a gradient on rank 1
  // only; c on no rank. stats [2] = (r + 1, 1).
  auto body = [](DistGroup& g) {
    const double r = g.rank();
    torch::Tensor a = torch::full({2, 3}, r + 1).requires_grad_(true);
    torch::Tensor b = torch::zeros({4}).requires_grad_(true);
    torch::Tensor c = torch::zeros({1}).requires_grad_(true);
    a.mutable_grad() = torch::full({2, 3}, r + 1);
    if (g.rank() == 1) b.mutable_grad() = torch::arange(4, torch::kFloat32);
    torch::Tensor stats = torch::tensor({r + 1, 1.0}, torch::kFloat64);
    AllReduceGradients(g, {a, b, c}, &stats);
    EXPECT_TRUE(torch::equal(a.grad(), torch::full({2, 3}, 3.0)));
    ASSERT_TRUE(b.grad().defined());
    EXPECT_TRUE(torch::equal(b.grad(), torch::arange(4, torch::kFloat32)));
    EXPECT_FALSE(c.grad().defined());  // as a single process: the optimizer skips it
    EXPECT_EQ(stats[0].item<double>(), 3.0);
    EXPECT_EQ(stats[1].item<double>(), 2.0);
    BroadcastParameters(g, {a});
    EXPECT_TRUE(torch::equal(a, torch::ones({2, 3})));  // rank 0's values
  };
  EXPECT_EQ(RunTwoRanks(body, body), 0);
}

TEST(DistGroup, ALostPeerIsADistErrorNotAHang) {
  auto parent = [](DistGroup& g) {
    std::vector<torch::Tensor> t = {torch::ones({8})};
    g.AllReduceSum(t);
    EXPECT_EQ(t[0][0].item<float>(), 2.0f);
    const auto start = std::chrono::steady_clock::now();
    std::vector<torch::Tensor> u = {torch::ones({8})};
    try {
      g.AllReduceSum(u);  // rank 1 has exited
      ADD_FAILURE() << "no error";
    } catch (const DistError& e) {
      EXPECT_NE(std::string(e.what()).find("rank 0: a peer was lost"), std::string::npos) << e.what();
    }
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 9.0);
  };
  auto child = [](DistGroup& g) {
    std::vector<torch::Tensor> t = {torch::ones({8})};
    g.AllReduceSum(t);
    _exit(0);  // dies without a word, as a killed rank
  };
  EXPECT_EQ(RunTwoRanks(parent, child), 0);
}

TEST(DistEnv, ReadsTorchrunVariables) {
  unsetenv("RANK");
  EXPECT_EQ(DistEnv::FromEnvironment().world_size, 1);
  setenv("RANK", "1", 1);
  setenv("WORLD_SIZE", "2", 1);
  setenv("MASTER_ADDR", "127.0.0.1", 1);
  setenv("MASTER_PORT", "29555", 1);
  const DistEnv env = DistEnv::FromEnvironment();
  EXPECT_EQ(env.rank, 1);
  EXPECT_EQ(env.world_size, 2);
  EXPECT_EQ(env.master_port, 29555);
  setenv("RANK", "2", 1);
  EXPECT_THROW(DistEnv::FromEnvironment(), InputError);  // rank >= world size
  setenv("RANK", "x", 1);
  EXPECT_THROW(DistEnv::FromEnvironment(), InputError);
  unsetenv("RANK");
  unsetenv("WORLD_SIZE");
  unsetenv("MASTER_ADDR");
  unsetenv("MASTER_PORT");
}

TEST(ProcessDevice, TheCpuStaysAndOneProcessKeepsItsDevice) {
  unsetenv("RANK");
  DistOptions o;
  o.nproc = 4;
  EXPECT_EQ(ProcessDevice(torch::kCPU, o), torch::Device(torch::kCPU));
  o.nproc = 1;
  // One process: the device asked, whatever it is (ParseDevice checked it exists).
  EXPECT_EQ(ProcessDevice(torch::Device(torch::kCUDA, 1), o), torch::Device(torch::kCUDA, 1));
}

TEST(ProcessDevice, SeveralProcessesOnGpusAreCheckedBeforeLaunching) {
  unsetenv("RANK");
  DistOptions o;
  o.nproc = 64;  // more than any machine here has
  auto message = [&](const torch::Device& d) {
    try {
      ProcessDevice(d, o);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  if (!NcclAvailable()) {
    // The CPU build (ParseDevice already refuses cuda there; this is the backstop).
    EXPECT_NE(message(torch::Device(torch::kCUDA, 0)).find("--device: cuda:0: expected cpu with several processes"),
              std::string::npos)
        << message(torch::Device(torch::kCUDA, 0));
    return;
  }
  EXPECT_NE(message(torch::Device(torch::kCUDA, 0)).find("--nproc: 64: expected at most"), std::string::npos)
      << message(torch::Device(torch::kCUDA, 0));
  o.nproc = 2;
  EXPECT_NE(message(torch::Device(torch::kCUDA, 1)).find("--device: cuda:1: expected cuda or auto"), std::string::npos)
      << message(torch::Device(torch::kCUDA, 1));
  if (torch::cuda::device_count() >= 2) {
    EXPECT_EQ(ProcessDevice(torch::Device(torch::kCUDA, 0), o), torch::Device(torch::kCUDA, 0));  // the launcher
  }
}

// NCCL: rank 0 here, rank 1 in a fresh copy of this binary (exec'd, not only forked: a CUDA
// context does not survive fork), each on its own GPU. Needs the CUDA build and 2 GPUs.
void NcclRankChecks(DistGroup& g) {
  const double r = g.rank();
  const torch::Device dev(torch::kCUDA, static_cast<torch::DeviceIndex>(g.rank()));
  const auto f = torch::TensorOptions().dtype(torch::kFloat32).device(dev);
  EXPECT_EQ(g.backend(), "NCCL");
  EXPECT_EQ(g.device(), dev);
  std::vector<torch::Tensor> t = {torch::full({5}, r + 1, f)};
  g.AllReduceSum(t);
  EXPECT_EQ(t[0].device(), dev);  // summed where it lives
  EXPECT_TRUE(torch::equal(t[0].cpu(), torch::full({5}, 3.0f)));
  // A CPU table (the validation errors) goes to the GPU and back into the caller's tensor.
  std::vector<torch::Tensor> table = {torch::full({2, 3}, r + 1, torch::kFloat64)};
  const torch::Tensor table_before = table[0];
  g.AllReduceSum(table);
  EXPECT_TRUE(table[0].device().is_cpu());
  EXPECT_TRUE(torch::equal(table_before, torch::full({2, 3}, 3.0, torch::kFloat64)));
  // The gradients as the CPU test has them, on the GPU; stats on the CPU.
  torch::Tensor a = torch::full({2, 3}, r + 1, f).requires_grad_(true);
  torch::Tensor b = torch::zeros({4}, f).requires_grad_(true);
  torch::Tensor c = torch::zeros({1}, f).requires_grad_(true);
  a.mutable_grad() = torch::full({2, 3}, r + 1, f);
  if (g.rank() == 1) b.mutable_grad() = torch::arange(4, f);
  torch::Tensor stats = torch::tensor({r + 1, 1.0}, torch::kFloat64);
  AllReduceGradients(g, {a, b, c}, &stats);
  EXPECT_EQ(a.grad().device(), dev);
  EXPECT_TRUE(torch::equal(a.grad().cpu(), torch::full({2, 3}, 3.0f)));
  ASSERT_TRUE(b.grad().defined());
  EXPECT_EQ(b.grad().device(), dev);
  EXPECT_TRUE(torch::equal(b.grad().cpu(), torch::arange(4, torch::kFloat32)));
  EXPECT_FALSE(c.grad().defined());
  EXPECT_TRUE(stats.device().is_cpu());
  EXPECT_EQ(stats[0].item<double>(), 3.0);
  EXPECT_EQ(stats[1].item<double>(), 2.0);
  BroadcastParameters(g, {a});
  EXPECT_EQ(a.device(), dev);
  EXPECT_TRUE(torch::equal(a.detach().cpu(), torch::ones({2, 3})));  // rank 0's values
}

TEST(DistGroupNccl, TwoGpusSumAndBroadcastOnTheirDevices) {
  if (!NcclAvailable()) GTEST_SKIP() << "this build's LibTorch has no NCCL (the CPU build)";
  const int gpus = torch::cuda::is_available() ? static_cast<int>(torch::cuda::device_count()) : 0;
  if (gpus < 2) GTEST_SKIP() << "needs 2 CUDA devices; this machine has " << gpus;
  DistOptions two;
  two.nproc = 2;
  if (std::getenv("NERFREG_DIST_TEST_NCCL_CHILD") != nullptr) {
    // Rank 1, from torchrun's variables as a launched worker has them.
    const torch::Device dev = ProcessDevice(torch::Device(torch::kCUDA, 0), two);
    EXPECT_EQ(dev, torch::Device(torch::kCUDA, 1));  // cuda:LOCAL_RANK
    auto group = DistGroup::FromEnvironment(60, dev);
    ASSERT_EQ(group->rank(), 1);
    NcclRankChecks(*group);
    return;
  }
  const int port = 20000 + (getpid() + 7919) % 20000;
  std::vector<std::string> env_strings;
  const std::vector<std::string> extra = {
      "NERFREG_DIST_TEST_NCCL_CHILD=1",     "RANK=1", "WORLD_SIZE=2", "LOCAL_RANK=1", "MASTER_ADDR=127.0.0.1",
      "MASTER_PORT=" + std::to_string(port)};
  for (char** e = environ; *e != nullptr; ++e) {
    const std::string kv = *e;
    bool replaced = false;
    for (const auto& x : extra) replaced |= kv.substr(0, kv.find('=') + 1) == x.substr(0, x.find('=') + 1);
    if (!replaced) env_strings.push_back(kv);
  }
  for (const auto& x : extra) env_strings.push_back(x);
  std::vector<char*> envp;
  for (auto& kv : env_strings) envp.push_back(kv.data());
  envp.push_back(nullptr);
  // Brief: the child prints its failures only, so a log counts this test's OK line once.
  std::string exe = "/proc/self/exe", filter = "--gtest_filter=DistGroupNccl.TwoGpusSumAndBroadcastOnTheirDevices",
              brief = "--gtest_brief=1";
  std::vector<char*> argv = {exe.data(), filter.data(), brief.data(), nullptr};
  const pid_t pid = fork();
  if (pid == 0) {
    execve(exe.c_str(), argv.data(), envp.data());
    _exit(127);
  }
  ASSERT_GT(pid, 0);
  try {
    EXPECT_EQ(ProcessDevice(torch::Device(torch::kCUDA, 0), two), torch::Device(torch::kCUDA, 0));
    DistEnv env;
    env.world_size = 2;
    env.master_port = port;
    auto group = DistGroup::Join(env, 60, torch::Device(torch::kCUDA, 0));
    NcclRankChecks(*group);
  } catch (const std::exception& e) {
    kill(pid, SIGKILL);
    ADD_FAILURE() << e.what();
  }
  int status = 0;
  waitpid(pid, &status, 0);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0)
      << "rank 1 (a copy of this test) failed: status " << status;
}

}  // namespace
}  // namespace nerfreg
