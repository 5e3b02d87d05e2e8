# nerfreg: `make demo` and `make test` set up, build, then run. See README.md.
BUILD_DIR ?= build
JOBS ?= $(shell nproc)
CMAKE_FLAGS ?=
FUZZ_SECONDS ?= 300
FUZZ_SECONDS_CI ?= 10

.PHONY: all setup build test demo fuzz bench clean cuda cuda-core

all: build

setup:
	@bash scripts/setup.sh

$(BUILD_DIR)/build.ninja:
	cmake -S . -B $(BUILD_DIR) -G Ninja -DCMAKE_BUILD_TYPE=Release $(CMAKE_FLAGS)

build: setup $(BUILD_DIR)/build.ninja
	cmake --build $(BUILD_DIR) -j $(JOBS)

# Also compiles and links the CUDA build (CI has the CUDA toolkit and no GPU to run it): the
# learned-core binary (nerfreg_core: the libraries with the CUDA kernels, device paths and NCCL, as
# the GPU check builds them) and the kernels' tests. The full binary is `make cuda`'s, not CI's: its
# other libraries have no CUDA code, and compiling them again took 210 of the check's 544 s. A compile
# check, never run here, so its C++ is built unoptimised (-O0, assertions on) in a folder of its own
# (build-cuda-check/; a quarter less compile time than -O3 on the heavy units), and `make cuda`'s
# build-cuda/ stays optimised. A machine without nvcc skips that step with a message. The fuzz step
# runs every torch-free fuzz target briefly; the torch-archive target is replayed by a ctest of the
# ordinary build instead of its own sanitized LibTorch build (docs/errors.md, Fuzzing).
test: build
	cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS) --timeout 300
	FUZZ_SECONDS=$(FUZZ_SECONDS_CI) FUZZ_TORCH=0 bash scripts/fuzz.sh
	CUDA_IF_TOOLKIT=1 CUDA_TARGETS="nerfreg_core nerfreg_nerf_kernels_test" CUDA_BUILD_DIR=build-cuda-check \
	  CMAKE_FLAGS="$(CMAKE_FLAGS) -DCMAKE_CXX_FLAGS_RELEASE=-O0" $(MAKE) cuda

# Sanitized (ASan + UBSan) unit tests of the parser layers, then every fuzz target.
fuzz: setup
	FUZZ_SECONDS=$(FUZZ_SECONDS) bash scripts/fuzz.sh

# All of nerfreg with the CUDA kernels against a CUDA LibTorch, in build-cuda/ (docs/gpu.md):
# TORCH_DIR=... for a LibTorch of your own, else the pinned PyPI wheel is fetched once. `make test`
# compiles it too. `make cuda-core`: the learned core alone, in build-cuda-core/, where Embree,
# Open3D, Ceres or OpenCV are missing (a GPU machine's; scripts/gpu_check.sh builds the same).
cuda: setup
	CUDA_SCOPE=full JOBS=$(JOBS) CMAKE_FLAGS="$(CMAKE_FLAGS)" bash scripts/build_cuda.sh

cuda-core:
	CUDA_SCOPE=core JOBS=$(JOBS) CMAKE_FLAGS="$(CMAKE_FLAGS)" bash scripts/build_cuda.sh

demo: build
	bash scripts/demo.sh

clean:
	rm -rf $(BUILD_DIR) build-cuda build-cuda-check build-cuda-core
