# Thin wrapper over CMake. `make run` and `make test` are all a new user needs.
BUILD    ?= build
ASAN     ?= build-asan
JOBS     ?= $(shell nproc 2>/dev/null || echo 2)
SCENE    ?= examples/sedov_3d.yaml
PYTHON   ?= /usr/bin/python3
CMAKE_ARGS ?=
DEB_DEPS := cmake make gcc pkg-config libyaml-dev libhdf5-dev check python3 python3-h5py python3-numpy python3-matplotlib

.PHONY: all deps build run test test-sanitize validate bench schema clean

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

run: build
	@mkdir -p out
	$(BUILD)/bin/ejecta run $(SCENE)

test: build
	ctest --test-dir $(BUILD) --output-on-failure -j $(JOBS)

# The whole suite under AddressSanitizer and UndefinedBehaviorSanitizer (CI runs it too).
test-sanitize: deps
	cmake -S . -B $(ASAN) -DCMAKE_BUILD_TYPE=Debug -DEJ_SANITIZE=ON $(CMAKE_ARGS)
	cmake --build $(ASAN) -j $(JOBS)
	ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
	  ctest --test-dir $(ASAN) --output-on-failure -j $(JOBS)

validate: build
	$(PYTHON) validation/run_all.py --build $(BUILD) --full

bench: build
	$(PYTHON) bench/run_all.py --build $(BUILD)

schema: build
	$(BUILD)/bin/ejecta schema -o schemas/scene.schema.json

clean:
	rm -rf $(BUILD) $(ASAN)
