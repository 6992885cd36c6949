# gmmcalib: `make serve` builds and serves the app; `make test` runs every test.
# Each target installs what it needs, idempotently. Never set RUSTFLAGS here: it would replace
# the wasm flags in .cargo/config.toml.

SHELL := bash
.SHELLFLAGS := -euo pipefail -c
WASM_TARGET := wasm32-unknown-unknown
# The CLI must match the wasm-bindgen crate exactly (pinned with = in Cargo.toml).
WASM_BINDGEN_VERSION := $(shell awk '/^name = "wasm-bindgen"$$/{getline; gsub(/[" ]/,""); sub("version=",""); print}' Cargo.lock)
WASM_OUT := target/$(WASM_TARGET)/release/gmmcalib.wasm
PORT ?= 5173

.PHONY: serve build wasm package test test-rust test-wasm test-package test-browser lint bench bench-browser bench-wasm setup-rust setup-node setup-package setup-browser clean

serve: wasm setup-node
	@echo "gmmcalib: open http://localhost:$(PORT)/"
	cd www && npx vite --port $(PORT) --strictPort

build: wasm setup-node
	cd www && npx vite build

test: lint test-rust test-wasm test-package test-browser

# Every target that builds for wasm32 (clippy's second run too) depends on setup-rust, so
# `make test` and `make serve` each work first on a machine that has only Rust.
lint: setup-rust
	cargo fmt --check
	cargo clippy --all-targets -- -D warnings
	cargo clippy --all-targets --features ts -- -D warnings
	cargo clippy --lib --target $(WASM_TARGET) -- -D warnings
	RUSTDOCFLAGS='-D warnings' cargo doc --no-deps --lib

test-rust:
	# --show-output: the accuracy tests print their error distributions.
	cargo test -- --show-output
	# The npm package's result types are what the Rust types declare (ts-rs, feature `ts`).
	cargo test --features ts --test report

test-wasm: setup-rust
	cargo test --target $(WASM_TARGET)

# The page's plain modules under Node (test/), then the page in Chromium (e2e/), one file at a
# time: each starts its own Chromium, and the machine has two cores.
test-browser: build setup-browser
	cd www && node --test --test-concurrency=1 test/ e2e/

bench: wasm
	cargo run --release --bin bench
	node www/bench/bench.mjs

# The page in Chromium timing a calibration on 1 and 2 workers; slow at paper scale.
bench-browser: build setup-browser
	cd www && node bench/browser.mjs

wasm: setup-rust
	cargo build --lib --release --target $(WASM_TARGET)
	wasm-bindgen --target web --out-dir www/pkg $(WASM_OUT)
	node www/tools/defaults.mjs

# The npm package (packages/gmmcalib): the page's wasm, one binary for Node and browsers,
# packed as packages/gmmcalib/gmmcalib-<version>.tgz.
package: wasm
	mkdir -p packages/gmmcalib/wasm
	cp www/pkg/gmmcalib.js www/pkg/gmmcalib_bg.wasm packages/gmmcalib/wasm/
	cd packages/gmmcalib && npm pack --silent

# The package packed, installed offline into a fresh project, calibrating twin rigs under Node
# against the native CLI, the drift check, and its types under tsc.
test-package: package setup-package
	cargo build --release --bin gmmcalib
	cd packages/gmmcalib && node --test --test-concurrency=1 test/

setup-rust:
	rustup target add $(WASM_TARGET) >/dev/null 2>&1 || rustup target add $(WASM_TARGET)
	@if [ "$$(wasm-bindgen --version 2>/dev/null | cut -d' ' -f2)" != "$(WASM_BINDGEN_VERSION)" ]; then \
		echo "installing wasm-bindgen-cli $(WASM_BINDGEN_VERSION) (one-off, a few minutes)"; \
		cargo install wasm-bindgen-cli --version $(WASM_BINDGEN_VERSION); \
	fi

setup-node:
	@if [ ! -d www/node_modules ] || [ www/package-lock.json -nt www/node_modules/.package-lock.json ]; then \
		cd www && npm ci --no-audit --no-fund; \
	fi

setup-package:
	@if [ ! -d packages/gmmcalib/node_modules ] || [ packages/gmmcalib/package-lock.json -nt packages/gmmcalib/node_modules/.package-lock.json ]; then \
		cd packages/gmmcalib && npm ci --no-audit --no-fund; \
	fi

setup-browser: setup-node
	@if [ ! -x /usr/bin/chromium ]; then \
		apt-get update && DEBIAN_FRONTEND=noninteractive apt-get install -y chromium; \
	fi

clean:
	cargo clean
	rm -rf www/pkg www/dist www/node_modules packages/gmmcalib/wasm packages/gmmcalib/node_modules packages/gmmcalib/*.tgz

# The paper's experiment on the digital twin (docs/accuracy.md, "The paper's experiment"):
# writes docs/experiment/{table.md,summary.json,*.svg,trials.csv}. FRAMES, TRIALS, SEED override.
.PHONY: experiment
experiment:
	cargo run --release --bin gmmcalib -- experiment --preset paper \
		--trials $(or $(TRIALS),100) --frames $(or $(FRAMES),10) --seed $(or $(SEED),2024) \
		--methods gmm,jrmpc,p2p,p2l,gicp --out docs/experiment
