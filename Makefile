# mosaicd — the two quick-start commands are `make demo` and `make test` (see README).
# Both run scripts/setup.sh first, which installs what a fresh Debian machine lacks.

CARGO ?= cargo
export MOSAICD_DATA ?= $(abspath ../shared/data)
ORACLE_DIR := target/oracle
# The target directory cargo uses (CARGO_TARGET_DIR when set), for the binaries cross-test runs.
TARGET_DIR := $(or $(CARGO_TARGET_DIR),target)

# aarch64 (Jetson, Raspberry Pi 5, RK3588) cross build with Debian's cross gcc; tests run under
# qemu-user (README, "Building for aarch64"). Only the aarch64 target reads these variables.
AARCH64 := aarch64-unknown-linux-gnu
AARCH64_SYSROOT := /usr/aarch64-linux-gnu
export CARGO_TARGET_AARCH64_UNKNOWN_LINUX_GNU_LINKER ?= aarch64-linux-gnu-gcc
export CARGO_TARGET_AARCH64_UNKNOWN_LINUX_GNU_RUNNER ?= qemu-aarch64 -L $(AARCH64_SYSROOT)
export BINDGEN_EXTRA_CLANG_ARGS_aarch64_unknown_linux_gnu ?= --sysroot=$(AARCH64_SYSROOT)
export CC_aarch64_unknown_linux_gnu ?= aarch64-linux-gnu-gcc
export AR_aarch64_unknown_linux_gnu ?= aarch64-linux-gnu-ar

.PHONY: test-note
test-note:
	$(TEST_NOTE)

.PHONY: setup demo recording test oracle skimage-negatives lint doc bench cross-build cross-lint cross-test \
	fuzz fuzz-smoke fuzz-build fuzz-smoke-build deb deb-arm64 deb-test

setup:
	@bash scripts/setup.sh

# Said before every cold build, so that nobody waits in silence (measured: 13 minutes for a cold
# release build on 2 cores).
BUILD_NOTE := @echo "make: building mosaicd in release mode: about 13 minutes on 2 cores from a cold checkout, seconds when up to date" >&2

# Quick start 1: the main job on a default recording — the daemon replays the demo recording (people
# in a corridor, built once from $(MOSAICD_DATA) through the reverse ISP by recordings/demo.toml) at its
# recorded rate with detection on, publishes over iceoryx2 and prints a summary (frames, detections,
# throughput, latency). scripts/demo.sh says what it does and falls back when the data is missing.
demo: setup
	$(BUILD_NOTE)
	$(CARGO) build --release
	bash scripts/demo.sh $(TARGET_DIR)/release/mosaicd

# The demo recording alone (recordings/out/demo.mcap, about 42 MB, never committed).
recording: setup
	$(BUILD_NOTE)
	$(CARGO) build --release
	$(TARGET_DIR)/release/mosaicd record --recipe recordings/demo.toml

# Reference fixtures from OpenCV / scikit-image / colour-demosaicing (tests/oracle/gen_*.py).
oracle: setup
	python3 tests/oracle/generate.py --out $(ORACLE_DIR)

# scikit-image's person-free sample photographs (from the installed wheel, no download) as PNGs, for
# `mosaicd train --negatives-dir target/skimage_negatives` (docs/detection.md, "The shipped models").
skimage-negatives: setup
	python3 scripts/skimage_negatives.py --out target/skimage_negatives

lint:
	$(CARGO) fmt --check
	$(CARGO) clippy --all-targets --quiet -- -D warnings

# No import circle between the files of src/, nor between its top-level modules (scripts/module_graph.py).
.PHONY: module-graph
module-graph:
	python3 scripts/module_graph.py

doc:
	RUSTDOCFLAGS="-D warnings" $(CARGO) doc --no-deps --quiet

# Quick start 2: the tests (what CI runs).
TEST_NOTE := @echo "make: building and running the tests: from a cold checkout the debug, doc and aarch64 builds take longer than the 13 minutes of a cold release build on 2 cores" >&2
test: test-note oracle lint
	MOSAICD_ORACLE=$(abspath $(ORACLE_DIR)) $(CARGO) test --all-targets --quiet
	MOSAICD_ORACLE=$(abspath $(ORACLE_DIR)) $(CARGO) test --doc --quiet
	$(MAKE) --no-print-directory doc
	$(MAKE) --no-print-directory cross-test
	$(MAKE) --no-print-directory module-graph

# The aarch64 build: only what cross-test runs, in one cargo call so that everything shares one build
# of the dependencies (a separate `cargo build` resolves features without the dev-dependencies and
# rebuilds 16 crates): the library's test binary, the gradient invariants, and the mosaicd binary
# (built because an integration test is).
cross-build: setup
	$(CARGO) test --target $(AARCH64) --lib --test gradient_invariants --no-run --quiet

# clippy for aarch64 (the NEON paths and everything cfg'd to x86-64 left out).
cross-lint: setup
	$(CARGO) clippy --target $(AARCH64) --all-targets --quiet -- -D warnings

# Under qemu-user: the library's whole unit-test suite (every kernel-equality test, `kernel_paths_*`:
# NEON against the scalar oracle; and every other unit test, whose code also runs the NEON path:
# about 3 minutes under qemu on 2 cores), the gradient invariants, then `mosaicd detect` on a real frame,
# whose boxes and scores must equal the x86-64 binary's (built the way `cargo test` builds it, so
# with the same features as the tests: no rebuild after them).
cross-test: cross-build
	$(CARGO) test --target $(AARCH64) --lib --quiet
	$(CARGO) test --target $(AARCH64) --test gradient_invariants --quiet
	$(CARGO) test --lib --test gradient_invariants --no-run --quiet
	bash scripts/cross_detect.sh $(TARGET_DIR)/debug/mosaicd \
	  "$(CARGO_TARGET_AARCH64_UNKNOWN_LINUX_GNU_RUNNER) $(TARGET_DIR)/$(AARCH64)/debug/mosaicd"

bench: setup
	$(CARGO) bench

# The Debian package (README, "Install on an edge box"; [package.metadata.deb] in Cargo.toml): the
# release build, then cargo-deb packages that binary (--no-build) with the units, the sysusers
# snippet, /etc/mosaicd/mosaicd.toml, the models, examples, docs and Python clients.
# -> $(TARGET_DIR)/debian/mosaicd_<version>-1_amd64.deb
DEB_VERSION := $(shell sed -n 's/^version = "\(.*\)"/\1/p' Cargo.toml | head -1)
DEB_AMD64 := $(TARGET_DIR)/debian/mosaicd_$(DEB_VERSION)-1_amd64.deb
deb: setup
	$(CARGO) build --release --quiet
	$(CARGO) deb --no-build --quiet --output $(DEB_AMD64)
	@echo "deb: $(DEB_AMD64)"

# The arm64 package, with the cross toolchain of `make cross-build` (stripped with
# aarch64-linux-gnu-strip). -> $(TARGET_DIR)/debian/mosaicd_<version>-1_arm64.deb
deb-arm64: setup
	$(CARGO) build --release --quiet --target $(AARCH64)
	$(CARGO) deb --no-build --quiet --target $(AARCH64) \
		--output $(TARGET_DIR)/debian/mosaicd_$(DEB_VERSION)-1_arm64.deb
	@echo "deb-arm64: $(TARGET_DIR)/debian/mosaicd_$(DEB_VERSION)-1_arm64.deb"

# CI (root): install the amd64 package with dpkg -i, verify the installed units, run the installed
# binary from / on an installed example config, then dpkg -r and dpkg --purge (scripts/deb_test.sh).
deb-test: deb
	bash scripts/deb_test.sh $(DEB_AMD64)

# Fuzzing (docs/fuzzing.md): the fuzz/ crate's libFuzzer targets, built on the stable toolchain with
# SanitizerCoverage (no sanitizer runtime), overflow checks and debug assertions on.
FUZZ_TARGETS := mcap_source raw_frame_message headerless_sidecar pgm_png camera_raw model_files config v4l2_unpack
FUZZ_TARGET_DIR ?= $(or $(CARGO_TARGET_DIR),$(CURDIR)/target)/fuzz
FUZZ_HOST := $(shell rustc -vV | sed -n 's/^host: //p')
FUZZ_BIN := $(FUZZ_TARGET_DIR)/$(FUZZ_HOST)/release
FUZZ_CORPUS ?= $(FUZZ_TARGET_DIR)/corpus
FUZZ_SECONDS ?= 600
# Stop a long run after this many executions (-1: no limit; `FUZZ_SECONDS=0 FUZZ_RUNS=10000000`
# runs each target to 10^7 executions).
FUZZ_RUNS ?= -1
FUZZ_SMOKE_SECONDS ?= 4
FUZZ_RUSTFLAGS := -Cpasses=sancov-module -Cllvm-args=-sanitizer-coverage-level=4 \
	-Cllvm-args=-sanitizer-coverage-inline-8bit-counters -Cllvm-args=-sanitizer-coverage-pc-table \
	-Cllvm-args=-sanitizer-coverage-trace-compares --cfg fuzzing -Cdebug-assertions -Coverflow-checks
# libFuzzer options: 2 GiB RSS limit, one job; crashes land in $(FUZZ_TARGET_DIR)/artifacts. Inputs
# up to 64 KiB, or 256 KiB for camera_raw (its SRF seed has 200,960 bytes; the shell sets $$ml).
FUZZ_FLAGS := -rss_limit_mb=2048 -max_len=$$ml -timeout=10 -print_final_stats=1
FUZZ_MAX_LEN := ml=65536; [ $$t = camera_raw ] && ml=262144;

# Targets that read files write their input to scratch files here: on tmpfs when there is one (a
# file per input on the development machine's disk held the fuzzer to ~400 inputs/s, on tmpfs
# model_files ran 29x faster), removed after the run.
FUZZ_SCRATCH ?= $(if $(wildcard /dev/shm/.),/dev/shm/mosaicd-fuzz-scratch,$(FUZZ_TARGET_DIR)/scratch)
fuzz fuzz-smoke: export MOSAICD_FUZZ_SCRATCH := $(FUZZ_SCRATCH)
# One core per run: the parallel V4L2 unpacker and rawloader use the global rayon pool, which
# would otherwise start a thread per core (v4l2_unpack used 1.3 cores).
fuzz fuzz-smoke: export RAYON_NUM_THREADS := 1

# --target keeps RUSTFLAGS off build scripts and proc macros.
fuzz-build: setup
	RUSTFLAGS="$(FUZZ_RUSTFLAGS)" $(CARGO) build --release --quiet --manifest-path fuzz/Cargo.toml \
		--target $(FUZZ_HOST) --target-dir $(FUZZ_TARGET_DIR)

# The smoke run's own build, cheap enough for CI (docs/fuzzing.md, "The CI smoke build"): the fuzz
# crate's `smoke` profile (opt-level 1, no debug info) with the fuzz flags on the crates that parse
# input only (fuzz/smoke_rustc.sh); -> $(FUZZ_TARGET_DIR)/<host>/smoke. `make fuzz` keeps the full
# build above. Cargo does not see the wrapper's flags, so a wrapper newer than the last smoke build
# removes that build first.
FUZZ_SMOKE_BIN := $(FUZZ_TARGET_DIR)/$(FUZZ_HOST)/smoke
FUZZ_SMOKE_STAMP := $(FUZZ_TARGET_DIR)/smoke-wrapper.stamp
fuzz-smoke-build: setup
	if [ fuzz/smoke_rustc.sh -nt $(FUZZ_SMOKE_STAMP) ]; then rm -rf $(FUZZ_SMOKE_BIN); fi
	FUZZ_RUSTFLAGS="$(FUZZ_RUSTFLAGS)" RUSTC_WRAPPER=$(CURDIR)/fuzz/smoke_rustc.sh $(CARGO) build \
		--profile smoke --quiet --manifest-path fuzz/Cargo.toml --target $(FUZZ_HOST) \
		--target-dir $(FUZZ_TARGET_DIR)
	touch $(FUZZ_SMOKE_STAMP)

# A few seconds per target (CI runs it: .ci/run), from the seeds alone (a fresh corpus each
# time, so that what long runs found does not make the smoke run differ), each bounded by
# `timeout` (libFuzzer's own timeout handler can hang without a sanitizer runtime). Any crash,
# timeout or leftover failure of a target fails the make target.
fuzz-smoke: fuzz-smoke-build
	rm -rf $(FUZZ_TARGET_DIR)/smoke-corpus
	bash fuzz/seed.sh $(FUZZ_TARGET_DIR)/smoke-corpus
	mkdir -p $(FUZZ_TARGET_DIR)/artifacts
	for t in $(FUZZ_TARGETS); do \
		$(FUZZ_MAX_LEN) \
		out=$$(timeout $$(( $(FUZZ_SMOKE_SECONDS) + 60 )) $(FUZZ_SMOKE_BIN)/$$t $(FUZZ_FLAGS) \
			-max_total_time=$(FUZZ_SMOKE_SECONDS) -artifact_prefix=$(FUZZ_TARGET_DIR)/artifacts/$$t- \
			$(FUZZ_TARGET_DIR)/smoke-corpus/$$t 2>&1); rc=$$?; \
		echo "$$out" | grep -aE '^Done' | sed "s/^/fuzz $$t: /"; \
		if [ $$rc -ne 0 ]; then echo "$$out" | tail -40; rm -rf $(FUZZ_SCRATCH); exit 1; fi; \
	done
	rm -rf $(FUZZ_SCRATCH)

# Long runs: FUZZ_SECONDS per target (default 600), or one target with FUZZ_TARGETS=name.
fuzz: fuzz-build
	bash fuzz/seed.sh $(FUZZ_CORPUS)
	mkdir -p $(FUZZ_TARGET_DIR)/artifacts
	for t in $(FUZZ_TARGETS); do \
		$(FUZZ_MAX_LEN) \
		$(FUZZ_BIN)/$$t $(FUZZ_FLAGS) -max_total_time=$(FUZZ_SECONDS) -runs=$(FUZZ_RUNS) \
			-artifact_prefix=$(FUZZ_TARGET_DIR)/artifacts/$$t- $(FUZZ_CORPUS)/$$t || { rm -rf $(FUZZ_SCRATCH); exit 1; }; \
	done
	rm -rf $(FUZZ_SCRATCH)
