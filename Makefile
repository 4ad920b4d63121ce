# mosaicd — the two quick-start commands are `make demo` and `make test` (see README).
# Both run scripts/setup.sh first, which installs what a fresh Debian machine lacks.

CARGO ?= cargo
export MOSAICD_DATA ?= $(abspath ../shared/data)
ORACLE_DIR := target/oracle

.PHONY: setup demo recording test oracle skimage-negatives lint doc bench fuzz fuzz-smoke fuzz-build

setup:
	@bash scripts/setup.sh

# Quick start 1: the main job on a bundled default — the daemon replays the demo recording (built once
# from a real 8-bit sensor frame in $(MOSAICD_DATA) by recordings/demo.toml) with detection on, publishes
# over iceoryx2 and prints a summary (frames, detections, throughput, latency).
demo: setup
	$(CARGO) build --release --quiet
	test -f recordings/out/demo.mcap || ./target/release/mosaicd record --recipe recordings/demo.toml
	./target/release/mosaicd run

# The demo recording alone (recordings/out/demo.mcap, about 28 MB, never committed).
recording: setup
	$(CARGO) build --release --quiet
	./target/release/mosaicd record --recipe recordings/demo.toml

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

doc:
	RUSTDOCFLAGS="-D warnings" $(CARGO) doc --no-deps --quiet

# Quick start 2: the tests (what CI runs).
test: oracle lint
	MOSAICD_ORACLE=$(abspath $(ORACLE_DIR)) $(CARGO) test --all-targets --quiet
	MOSAICD_ORACLE=$(abspath $(ORACLE_DIR)) $(CARGO) test --doc --quiet
	$(MAKE) --no-print-directory doc
	$(MAKE) --no-print-directory fuzz-smoke

bench: setup
	$(CARGO) bench

# Fuzzing (docs/fuzzing.md): the fuzz/ crate's libFuzzer targets, built on the stable toolchain with
# SanitizerCoverage (no sanitizer runtime), overflow checks and debug assertions on.
FUZZ_TARGETS := mcap_source raw_frame_message headerless_sidecar pgm_png camera_raw model_files config v4l2_unpack
FUZZ_TARGET_DIR ?= $(or $(CARGO_TARGET_DIR),$(CURDIR)/target)/fuzz
FUZZ_HOST := $(shell rustc -vV | sed -n 's/^host: //p')
FUZZ_BIN := $(FUZZ_TARGET_DIR)/$(FUZZ_HOST)/release
FUZZ_CORPUS ?= $(FUZZ_TARGET_DIR)/corpus
FUZZ_SECONDS ?= 600
FUZZ_SMOKE_SECONDS ?= 4
FUZZ_RUSTFLAGS := -Cpasses=sancov-module -Cllvm-args=-sanitizer-coverage-level=4 \
	-Cllvm-args=-sanitizer-coverage-inline-8bit-counters -Cllvm-args=-sanitizer-coverage-pc-table \
	-Cllvm-args=-sanitizer-coverage-trace-compares --cfg fuzzing -Cdebug-assertions -Coverflow-checks
# libFuzzer options: 2 GiB RSS limit, 64 KiB inputs, one job; crashes land in $(FUZZ_TARGET_DIR)/artifacts.
FUZZ_FLAGS := -rss_limit_mb=2048 -max_len=65536 -timeout=10 -print_final_stats=1

# Targets that read files write their input to scratch files here.
fuzz fuzz-smoke: export MOSAICD_FUZZ_SCRATCH := $(FUZZ_TARGET_DIR)/scratch

# --target keeps RUSTFLAGS off build scripts and proc macros.
fuzz-build:
	RUSTFLAGS="$(FUZZ_RUSTFLAGS)" $(CARGO) build --release --quiet --manifest-path fuzz/Cargo.toml \
		--target $(FUZZ_HOST) --target-dir $(FUZZ_TARGET_DIR)

# A few seconds per target (CI, through `make test`), from the seeds alone (a fresh corpus each
# time, so that what long runs found does not make the smoke run differ), each bounded by
# `timeout` (libFuzzer's own timeout handler can hang without a sanitizer runtime).
fuzz-smoke: fuzz-build
	rm -rf $(FUZZ_TARGET_DIR)/smoke-corpus
	bash fuzz/seed.sh $(FUZZ_TARGET_DIR)/smoke-corpus
	mkdir -p $(FUZZ_TARGET_DIR)/artifacts
	for t in $(FUZZ_TARGETS); do \
		out=$$(timeout $$(( $(FUZZ_SMOKE_SECONDS) + 60 )) $(FUZZ_BIN)/$$t $(FUZZ_FLAGS) \
			-max_total_time=$(FUZZ_SMOKE_SECONDS) -artifact_prefix=$(FUZZ_TARGET_DIR)/artifacts/$$t- \
			$(FUZZ_TARGET_DIR)/smoke-corpus/$$t 2>&1); rc=$$?; \
		echo "$$out" | grep -aE '^Done' | sed "s/^/fuzz $$t: /"; \
		if [ $$rc -ne 0 ]; then echo "$$out" | tail -40; exit 1; fi; \
	done

# Long runs: FUZZ_SECONDS per target (default 600), or one target with FUZZ_TARGETS=name.
fuzz: fuzz-build
	bash fuzz/seed.sh $(FUZZ_CORPUS)
	mkdir -p $(FUZZ_TARGET_DIR)/artifacts
	for t in $(FUZZ_TARGETS); do \
		$(FUZZ_BIN)/$$t $(FUZZ_FLAGS) -max_total_time=$(FUZZ_SECONDS) \
			-artifact_prefix=$(FUZZ_TARGET_DIR)/artifacts/$$t- $(FUZZ_CORPUS)/$$t || exit 1; \
	done
