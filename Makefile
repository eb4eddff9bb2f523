# btfgmm: `make demo` installs what is missing, builds in Release and runs the built-in
# example; `make test` builds and runs every test. Both work on a fresh Debian machine.
BUILD ?= build
JOBS ?= $(shell nproc 2>/dev/null || echo 2)
# Warnings are errors in CI (CI=true) and wherever WERROR=ON is given.
WERROR ?= $(if $(filter true 1 yes,$(CI)),ON,OFF)
CMAKE_ARGS ?=

.PHONY: all deps configure build demo test bench asan fuzz fuzz-long sizes layers format clean

all: build

deps:
	@scripts/install-deps

configure: deps
	@cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release -DBTFGMM_WERROR=$(WERROR) $(CMAKE_ARGS) >/dev/null

build: configure
	@cmake --build $(BUILD) -j$(JOBS)

demo: build
	@scripts/demo $(BUILD)/btfgmm

test: build
	@cd $(BUILD) && ctest --output-on-failure -j$(JOBS)

# Speed and memory against Armadillo's gmm_diag (one thread and all; the thread scaling), then
# the paper's full workload (64 x 64 tile, M = 600, 40 iterations) and the decoding of its
# model, then rendering, then the kernels alone (Google Benchmark), then the comparison
# methods (PCA BTF against numpy's SVD, every method's decoding). Minutes; docs/BENCHMARKS.md
# keeps the figures. bench/bench-em-history.sh (not run here: it builds an earlier revision)
# times an EM iteration beside an earlier revision's.
bench: build
	@$(BUILD)/bench_fit --tile 12 --components 600 --iterations 5 --threads 1,0 --scaling
	@$(BUILD)/bench_fit --size 64 --tile 64 --components 600 --iterations 40 --no-peer \
		--save $(BUILD)/bench-64.btfgmm
	@$(BUILD)/bench_fit --decode $(BUILD)/bench-64.btfgmm
	@$(BUILD)/bench_render --runs 5
	@$(BUILD)/bench_kernels
	@$(BUILD)/bench_methods

# The test suite under AddressSanitizer and UndefinedBehaviorSanitizer, in build-asan (without
# the benchmarks). ASAN_TESTS / ASAN_EXCLUDE (ctest -R / -E regular expressions) choose tests.
# Debug keeps the assertions; CMakeLists.txt sets -O1 -g1 for sanitizer builds. Leaks inside
# Mesa's lavapipe, which runs the GPU tests, are the driver's (tests/lsan.supp); the commands
# the tests run (decode, eval, compare on lavapipe) print no table of the suppressions used.
ASAN_TESTS ?=
ASAN_EXCLUDE ?=
asan:
	@$(MAKE) --no-print-directory configure BUILD=build-asan CMAKE_ARGS="-DBTFGMM_ASAN=ON -DCMAKE_BUILD_TYPE=Debug -DBTFGMM_BENCH=OFF"
	@cmake --build build-asan -j$(JOBS)
	@cd build-asan && LSAN_OPTIONS=suppressions=$(CURDIR)/tests/lsan.supp:print_suppressions=0 ctest --output-on-failure -j$(JOBS) $(if $(ASAN_TESTS),-R '$(ASAN_TESTS)') $(if $(ASAN_EXCLUDE),-E '$(ASAN_EXCLUDE)')

# The libFuzzer targets (tests/fuzz/), built with clang in build-fuzz and run FUZZ_SECONDS each,
# all at once, from the committed corpora (tests/fuzz/corpus/). CI runs them for seconds, so
# that they build; `make fuzz-long` runs each for FUZZ_LONG_SECONDS (5 minutes: OpenEXR's
# offset bug took 16,174 executions, more than CI's seconds reach), keeps what reached new
# code in the committed corpora (FUZZ_KEEP=1), and is run before any change to a reader is
# done; docs/BENCHMARKS.md records its executions. On a shared machine: nice -n 10 make fuzz-long.
FUZZ_SECONDS ?= 60
FUZZ_LONG_SECONDS ?= 300
fuzz: deps
	@scripts/fuzz $(FUZZ_SECONDS)

fuzz-long: deps
	@FUZZ_KEEP=1 scripts/fuzz $(FUZZ_LONG_SECONDS)

# The size limits of the library's sources (docs/ARCHITECTURE.md): files <= 600 lines,
# functions <= 80 lines.
sizes:
	@scripts/check-sizes src cli bench python

# The layers include one another one way (docs/ARCHITECTURE.md).
layers:
	@scripts/check-layers

format:
	@clang-format -i $$(git ls-files '*.cpp' '*.hpp')

clean:
	@rm -rf $(BUILD) build-asan build-fuzz out
