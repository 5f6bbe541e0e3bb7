# Thin wrapper so the README's two commands stay two words each. Everything real is in CMake.
PRESET ?= release
BUILD  := build/$(PRESET)
JOBS   ?= $(shell nproc)
ARGS   ?= serve

.PHONY: deps build run run-edge test check bench load load-replicas load-game image-check container-check format tidy mutation clean

deps:
	bash docker/install-deps.sh

build: deps
	cmake --preset $(PRESET) >/dev/null
	cmake --build $(BUILD) -j $(JOBS)

# Starts the HTTP service with its embedded defaults (./data, backend auto, 127.0.0.1:8080);
# `make run ARGS="serve --port 9000"` or any other command (`make run ARGS="analyze ..."`).
run: build
	./$(BUILD)/textond $(ARGS)

# The service behind the nginx edge of deploy/ on :8080 (textond itself on 127.0.0.1:8081):
# how one machine should face a network (deploy/README.md "Hostile clients").
run-edge: build
	deploy/local/run-edge.sh 8080 -- $(filter-out serve,$(ARGS))

# One more test than cores: the end-to-end tests wait on servers and processes as much as they
# compute (2 cores: 268-300 s at -j 3 against 330 s at -j 2, same tests). The longest tests
# (clang-tidy, the fuzz smoke run, the image) run alone whatever -j says (RUN_SERIAL).
TEST_JOBS ?= $(shell echo $$(( $$(nproc) + 1 )))

test: build
	cd $(BUILD) && ctest --output-on-failure -j $(TEST_JOBS)

# The inner loop: every test but clang-tidy (label style), the libFuzzer smoke run (fuzz), the
# browser tests (browser), the container tests and the long suites (long: the memory bounds under
# load, the verdict on its corpora); about 5 minutes on 2 cores. `make test` is the full suite CI
# runs.
# Two more tests than cores: without the long suites more of them wait on servers (2 cores: 282 s
# at -j 4 against 306 s at -j 3, same tests).
CHECK_JOBS ?= $(shell echo $$(( $$(nproc) + 2 )))

check: build
	cd $(BUILD) && ctest --output-on-failure -j $(CHECK_JOBS) -LE '^(style|fuzz|browser|container|long)$$'

bench: build
	./$(BUILD)/textond bench analyze

# Tile throughput with wrk against a fresh server (tests/load/load_test.sh; not part of `test`).
load: build
	tests/load/load_test.sh

# Two replicas sharing Redis behind the nginx edge, with a 60-second soak (deploy/README.md "Run at scale").
load-replicas: build
	tests/load/load_test.sh --replicas

# A game client flying over the plane, three rings of tiles a frame (tests/load/game_client.py),
# against one server and through the edge.
load-game: build
	tests/load/game_client_test.sh

# The Dockerfile's two stages in debootstrapped chroots (root, network, 10-20 minutes).
image-check:
	docker/chroot_build_test.sh

# What podman runs (label `container`): the image against the host build, the compose stack
# and `kube play` of deploy/base (tests/deploy/: container_test.sh, compose_test.sh,
# kube_play_test.py).
container-check: build
	cd $(BUILD) && ctest --output-on-failure -L '^container$$'

format:
	clang-format -i $$(git ls-files '*.h' '*.cpp')

# clang-tidy 22 over core/, render/, server/, api/ (what CI's tidy_check runs; about 5 minutes
# from nothing on 2 cores, then only what changed).
tidy: build
	tests/style/tidy_check.sh $(BUILD)

# One-line defects in the critical code, one at a time: every one must fail a test (README
# "Mutation check"); a few minutes, not part of `make test`.
mutation: build
	BUILD=$(BUILD) tests/mutation/run.sh

clean:
	rm -rf build
