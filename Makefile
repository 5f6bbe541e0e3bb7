# Thin wrapper so the README's two commands stay two words each. Everything real is in CMake.
PRESET ?= release
BUILD  := build/$(PRESET)
JOBS   ?= $(shell nproc)
ARGS   ?= --help

.PHONY: deps build run test bench format clean

deps:
	bash docker/install-deps.sh

build: deps
	cmake --preset $(PRESET) >/dev/null
	cmake --build $(BUILD) -j $(JOBS)

# Starts textond (for now the CLI; `make run ARGS="analyze ..."`).
run: build
	./$(BUILD)/textond $(ARGS)

test: build
	cd $(BUILD) && ctest --output-on-failure -j $(JOBS)

bench: build
	./$(BUILD)/textond bench analyze

format:
	clang-format -i $$(git ls-files '*.h' '*.cpp')

clean:
	rm -rf build
