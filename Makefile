# mosaicd — the two quick-start commands are `make demo` and `make test` (see README).
# Both run scripts/setup.sh first, which installs what a fresh Debian machine lacks.

CARGO ?= cargo
export MOSAICD_DATA ?= $(abspath ../shared/data)
ORACLE_DIR := target/oracle

.PHONY: setup demo test oracle lint doc bench

setup:
	@bash scripts/setup.sh

# Quick start 1: the main job on a bundled default.
demo: setup
	$(CARGO) build --release --quiet
	./target/release/mosaicd gradients $(MOSAICD_DATA)/raw/nikon_dsc1339_isp/DSC_1339_768x512_rggb.raw \
		--width 768 --height 512 --bit-depth 14 --cfa RGGB --black 600 --white 15520 --out out/demo

# Reference fixtures from OpenCV / scikit-image / colour-demosaicing (tests/oracle/gen_*.py).
oracle: setup
	python3 tests/oracle/generate.py --out $(ORACLE_DIR)

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

bench: setup
	$(CARGO) bench
