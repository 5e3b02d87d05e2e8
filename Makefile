# nerfreg: `make demo` and `make test` set up, build, then run. See README.md.
BUILD_DIR ?= build
JOBS ?= $(shell nproc)
CMAKE_FLAGS ?=
FUZZ_SECONDS ?= 300
FUZZ_SECONDS_CI ?= 10

.PHONY: all setup build test demo fuzz bench clean

all: build

setup:
	@bash scripts/setup.sh

$(BUILD_DIR)/build.ninja:
	cmake -S . -B $(BUILD_DIR) -G Ninja -DCMAKE_BUILD_TYPE=Release $(CMAKE_FLAGS)

build: setup $(BUILD_DIR)/build.ninja
	cmake --build $(BUILD_DIR) -j $(JOBS)

test: build
	cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS) --timeout 300
	FUZZ_SECONDS=$(FUZZ_SECONDS_CI) bash scripts/fuzz.sh

# Sanitized (ASan + UBSan) unit tests of the parser layers, then every fuzz target.
fuzz: setup
	FUZZ_SECONDS=$(FUZZ_SECONDS) bash scripts/fuzz.sh

demo: build
	bash scripts/demo.sh

clean:
	rm -rf $(BUILD_DIR)
