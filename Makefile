# Thin wrapper over CMake. `make run` and `make test` are all a new user needs.
BUILD    ?= build
ASAN     ?= build-asan
JOBS     ?= $(shell nproc 2>/dev/null || echo 2)
SCENE    ?= examples/buried_charge.yaml
PYTHON   ?= /usr/bin/python3
CMAKE_ARGS ?=
DEB_DEPS := cmake make gcc pkg-config libyaml-dev libhdf5-dev check python3 python3-h5py python3-numpy python3-matplotlib python3-scipy

.PHONY: all deps build run test test-sanitize validate bench schema clean
.PHONY: fuzz docs

all: build

# Installs the Debian packages that are missing (as root, or through sudo).
deps:
	@missing=""; for p in $(DEB_DEPS); do dpkg -s $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
	if [ -n "$$missing" ]; then \
	  echo "installing:$$missing"; \
	  if [ "$$(id -u)" = 0 ]; then SUDO=""; else SUDO="sudo"; fi; \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq $$missing; \
	fi

$(BUILD)/CMakeCache.txt: | deps
	cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release $(CMAKE_ARGS)

build: deps $(BUILD)/CMakeCache.txt
	cmake --build $(BUILD) -j $(JOBS)

# The default scene is the buried charge: afterwards, the soil bubble (height and width against
# time, CSV and PNG) and cuts through the symmetry plane coloured by speed (PNG).
run: build
	@mkdir -p out
	$(BUILD)/bin/ejecta run $(SCENE)
	@if [ "$(SCENE)" = "examples/buried_charge.yaml" ]; then $(PYTHON) tools/bubble.py out/buried_charge.h5; fi

test: build
	ctest --test-dir $(BUILD) --output-on-failure -j $(JOBS)

# The whole suite under AddressSanitizer and UndefinedBehaviorSanitizer (CI runs it too).
test-sanitize: deps
	cmake -S . -B $(ASAN) -DCMAKE_BUILD_TYPE=Debug -DEJ_SANITIZE=ON $(CMAKE_ARGS)
	cmake --build $(ASAN) -j $(JOBS)
	ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
	  ctest --test-dir $(ASAN) --output-on-failure -j $(JOBS)

# ParaView (pvpython) and Xvfb for the ParaView check of the output (test_paraview renders
# through ParaView under a virtual X server; it is skipped by `make test` when they are absent),
# and PySPH, the peer that validation/pysph_taylor_bar runs in the same command.
VALIDATE_DEPS := paraview python3-paraview xvfb xauth python3-pysph
validate: build
	@$(MAKE) --no-print-directory deps DEB_DEPS="$(VALIDATE_DEPS)"
	ctest --test-dir $(BUILD) --output-on-failure -R '^test_paraview$$'
	$(PYTHON) validation/run_all.py --build $(BUILD) --full

# The peers the benchmarks run beside ejecta: PySPH (bench/pysph_sod.py) and LAMMPS with its
# examples (bench/lammps_peri).
BENCH_DEPS := python3-pysph lammps lammps-examples
bench: build
	@$(MAKE) --no-print-directory deps DEB_DEPS="$(BENCH_DEPS)"
	$(PYTHON) bench/run_all.py --build $(BUILD)

schema: build
	$(BUILD)/bin/ejecta schema -o schemas/scene.schema.json

clean:
	rm -rf $(BUILD) $(ASAN)

# Plugin reference pages from the parameter tables (test_docs fails when they are stale).
docs: build
	mkdir -p docs/plugins && $(BUILD)/bin/ejecta describe --markdown -o docs/plugins

# libFuzzer harnesses (clang; -fsanitize=fuzzer,address,undefined) on the scene parser and
# validator and on the CSV particle importer, FUZZ_SECONDS each; corpora in tests/fuzz/.
FUZZ_SECONDS ?= 60
FUZZ_BUILD   ?= build-fuzz
fuzz:
	@command -v clang >/dev/null || { echo "make fuzz needs clang (apt-get install clang)"; exit 2; }
	tests/fuzz/build.sh $(FUZZ_BUILD)
	tests/fuzz/run.sh $(FUZZ_BUILD) $(FUZZ_SECONDS)
