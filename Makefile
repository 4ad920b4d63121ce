# mosaicd — the two quick-start commands are `make demo` and `make test` (see README).
# Both run scripts/setup.sh first, which installs what a fresh Debian machine lacks.

CARGO ?= cargo
export MOSAICD_DATA ?= $(abspath ../shared/data)
ORACLE_DIR := target/oracle

.PHONY: setup demo recording test oracle skimage-negatives lint doc bench

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

# No import circle between the files of src/, nor between its top-level modules (scripts/module_graph.py).
.PHONY: module-graph
module-graph:
	python3 scripts/module_graph.py

doc:
	RUSTDOCFLAGS="-D warnings" $(CARGO) doc --no-deps --quiet

# Quick start 2: the tests (what CI runs).
test: oracle lint
	MOSAICD_ORACLE=$(abspath $(ORACLE_DIR)) $(CARGO) test --all-targets --quiet
	MOSAICD_ORACLE=$(abspath $(ORACLE_DIR)) $(CARGO) test --doc --quiet
	$(MAKE) --no-print-directory doc
	$(MAKE) --no-print-directory module-graph

bench: setup
	$(CARGO) bench
