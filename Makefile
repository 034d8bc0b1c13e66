# SPDX-License-Identifier: Apache-2.0
# Thin wrapper around CMake (the presets in CMakePresets.json hold the details).
#   make study       install dependencies if missing, build the lfi program (Release), run the reference study
#   make check       same set-up, then build everything (tests, fuzz replays, benchmarks) and run every test
#   make check-format  fail on a source file that differs from .clang-format
#   make check-asan  the tests under AddressSanitizer + UndefinedBehaviorSanitizer (clang, build/asan)
#   make check-tsan  the threaded parts' tests under ThreadSanitizer
#   make fuzz        the libFuzzer targets (build/asan), each for FUZZ_SECONDS on its corpus (docs/reliability.md)
JOBS ?= 2
STUDY_OUT ?= out/study
STUDY_QUALITY ?= default
FUZZ_SECONDS ?= 30
CMAKE_WERROR := $(if $(CI),-DLFI_WERROR=ON,)
LFI := build/release/apps/lfi

.PHONY: deps configure build build-lfi study check check-format check-asan check-tsan fuzz clean

deps:
	@scripts/install-deps.sh

configure: deps
	@cmake --preset release $(CMAKE_WERROR) >/dev/null

build: configure
	@cmake --build --preset release -j $(JOBS)

# Only the lfi program and the libraries it links: no tests, fuzz replays or benchmarks.
build-lfi: configure
	@cmake --build --preset release -j $(JOBS) --target lfi

study: build-lfi
	$(LFI) study --out $(STUDY_OUT) --quality $(STUDY_QUALITY) --force

check: build
	ctest --preset release -j $(JOBS)

check-format:
	@git ls-files '*.cpp' '*.h' | xargs clang-format --dry-run -Werror
	@echo "check-format: every source file matches .clang-format"

check-asan: deps
	@cmake --preset asan $(CMAKE_WERROR) >/dev/null
	@cmake --build --preset asan -j $(JOBS)
	ctest --preset asan -j $(JOBS)

check-tsan: deps
	@cmake --preset tsan $(CMAKE_WERROR) >/dev/null
	@cmake --build --preset tsan -j $(JOBS)
	scripts/check-tsan.sh

fuzz: deps
	@cmake --preset asan $(CMAKE_WERROR) >/dev/null
	@cmake --build --preset fuzz -j $(JOBS)
	scripts/run-fuzzers.sh $(FUZZ_SECONDS)

clean:
	rm -rf build
