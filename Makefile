# Two commands do everything: `make demo` and `make test`. Both set up first.
SHELL := /bin/bash
.SHELLFLAGS := -euo pipefail -c
.DEFAULT_GOAL := help

CARGO := .ci/cargo
EXAMPLES := $(patsubst examples/%.rs,%,$(wildcard examples/*.rs))
FIRMWARE_DIR := target/avr-atmega328p/release/examples
FIRMWARE := $(addprefix $(FIRMWARE_DIR)/,$(addsuffix .elf,$(EXAMPLES)))

.PHONY: help setup firmware fixtures sizes lint fmt-check clippy docs host-test test demo serve interop bench bench-features fuzz soak

help:
	@echo "make demo   - build the Uno slave and poll it on a virtual Uno"
	@echo "make serve EXAMPLE=uno_slave - keep a virtual Uno running for QModMaster or any master"
	@echo "make test   - set up, lint, build every firmware, run all tests"
	@echo "make firmware - build every example for the Uno ($(FIRMWARE_DIR))"
	@echo "make bench  - size-issue targets (met or not), flash, RAM, stack, interrupt cycles, turnaround, throughput -> bench/results.md"
	@echo "make fuzz   - coverage-guided fuzz targets (FUZZ_SECONDS each), then a long property run"
	@echo "make soak   - 100000 mixed transactions against uno_slave in simavr (~15 min; SOAK_TRANSACTIONS)"

setup:
	@.ci/setup

# The examples that keep the clock (feature millis) are a build of their own, so that the
# others carry no clock.
firmware: setup
	$(CARGO) uno --examples --features examples
	$(CARGO) uno --example uno_slave --example dip_switch --features examples,millis
	$(CARGO) uno --example ascii --features examples,ascii
	$(CARGO) uno --example configurable --features examples,eeprom-settings,ascii,device-id,$(OPTIONAL)
	@.ci/sizes $(FIRMWARE)
	@.ci/no-panic $(FIRMWARE)

sizes: firmware

# A user's firmware in the avr-hal template's form (fixtures/), outside the workspace, built
# against avr-device 0.8.1 (arduino-hal's) and 0.9: tests/sim_template.rs runs both ELFs.
FIXTURES := $(wildcard fixtures/template-*)
fixtures: setup
	@for f in $(FIXTURES); do \
		echo "fixture: $$f"; \
		(cd $$f && ../../.ci/cargo build --release --locked --target-dir ../../target/fixtures); \
	done
	@.ci/sizes $(foreach f,$(FIXTURES),target/fixtures/avr-none/release/$(subst .,,$(notdir $(f))).elf)


fmt-check: setup
	$(CARGO) fmt --all --check

# The optional function codes, checked and tested as a second build.
OPTIONAL := diagnostics,extra-fc,write-protect

clippy: setup
	$(CARGO) clippy --workspace --all-targets -- -D warnings
	$(CARGO) clippy -p avr-modbus-slave --all-targets --features $(OPTIONAL),device-id -- -D warnings
	$(CARGO) clippy -p avr-modbus-slave --all-targets --features ascii -- -D warnings
	$(CARGO) clippy -p avr-modbus-slave --all-targets --features $(OPTIONAL),eeprom-settings,ufmt -- -D warnings
	$(CARGO) uno-clippy --examples --features examples -- -D warnings
	$(CARGO) uno-clippy --examples --features examples,millis,ascii,device-id,$(OPTIONAL),eeprom-settings,ufmt -- -D warnings

docs: setup
	RUSTDOCFLAGS="-D warnings" $(CARGO) doc --no-deps -p avr-modbus-slave --features $(OPTIONAL),eeprom-settings,ufmt,device-id,ascii
	RUSTDOCFLAGS="-D warnings -C target-cpu=atmega328p" $(CARGO) doc --no-deps -p avr-modbus-slave --release \
		-Zjson-target-spec -Zbuild-std=core --target avr-atmega328p.json --features $(OPTIONAL),eeprom-settings,ufmt,millis,ascii

lint: fmt-check clippy docs

host-test: setup firmware fixtures
	$(CARGO) test --workspace --exclude virtual-uno
	$(CARGO) test -p virtual-uno --bins
	$(CARGO) test -p avr-modbus-slave --features $(OPTIONAL) --lib --test optional_functions --test exceptions --test adu --test framer --test bank --test map --test random_frames
	$(CARGO) test -p avr-modbus-slave --features $(OPTIONAL),eeprom-settings --test settings --test settings_slots --test random_frames \
		--test sim_configurable --test sim_settings_reset --test sim_silent --test sim_diagnostics
	$(CARGO) test -p avr-modbus-slave --features $(OPTIONAL),eeprom-settings,ascii --test settings_ascii
	$(CARGO) test -p avr-modbus-slave --features $(OPTIONAL),eeprom-settings --doc
	$(CARGO) test -p avr-modbus-slave --features ufmt --test ufmt
	$(CARGO) test -p avr-modbus-slave --features device-id --test device_id --test map --test sim_device_id --test random_frames
	$(CARGO) test -p avr-modbus-slave --features ascii --test ascii --test sim_ascii --test framer --test adu --test random_frames
	$(CARGO) test -p avr-modbus-slave --features ascii --doc

test: lint firmware host-test interop

EXAMPLE ?= uno_slave

# The firmware on a virtual Uno (simavr on a pseudo-terminal), polled by mbpoll.
demo: firmware
	demo/demo.sh

# Keeps a virtual Uno running for QModMaster or any master: make serve EXAMPLE=NAME ARGS="..."
serve: firmware
	demo/serve.sh $(EXAMPLE) $(ARGS)

# mbpoll, pymodbus, minimalmodbus and libmodbus against the firmware on the virtual Uno, with answer rates.
interop: firmware
	$(CARGO) test -p virtual-uno --test interop -- --nocapture --test-threads=1

bench: setup firmware bench-features
	$(CARGO) run --release -p bench

# minimal built with each optional feature, as `firmware` builds it, into its own target
# directory (firmware's ELF files stay as they are): make bench compares their sizes.
BENCH_FEATURES_DIR := target/bench-features
BENCH_FEATURES := extra-fc diagnostics write-protect device-id millis ascii
bench-features: setup
	@mkdir -p $(BENCH_FEATURES_DIR)
	@for f in "" $(BENCH_FEATURES); do \
		$(CARGO) uno --example minimal --features examples$${f:+,$$f} --target-dir $(BENCH_FEATURES_DIR); \
		cp $(BENCH_FEATURES_DIR)/avr-atmega328p/release/examples/minimal.elf $(BENCH_FEATURES_DIR)/minimal$${f:++$$f}.elf; \
	done

# Coverage-guided fuzzing (cargo-fuzz, libFuzzer): every target under fuzz/ (frames, events,
# ascii, settings; the fuzz crate builds every optional feature) for FUZZ_SECONDS each, with
# its executions, rate and findings (.ci/fuzz). Then a long seeded run of the property tests
# that `make test` runs 2000 cases of (PROPERTY_CASES, FUZZ_SEED), with FC 43 and ASCII.
FUZZ_SECONDS ?= 600
PROPERTY_CASES ?= 1000000
FUZZ_PROPERTY_FEATURES := $(OPTIONAL),ascii,device-id
fuzz: setup
	@.ci/fuzz $(FUZZ_SECONDS)
	FUZZ_CASES=$(PROPERTY_CASES) FUZZ_SEED=$${FUZZ_SEED:-$$(date +%s)} $(CARGO) test --release -p avr-modbus-slave \
		--features $(FUZZ_PROPERTY_FEATURES) --test random_frames -- --nocapture
	@echo "fuzz: $(PROPERTY_CASES) cases per property, 4 properties, features $(FUZZ_PROPERTY_FEATURES)"

# Long mixed-request run against uno_slave at 19200 8E1 with a reference model of its bank
# (100000: ~1400 s simulated, ~15 min wall). `make test` runs 2000.
SOAK_TRANSACTIONS ?= 100000
soak: setup firmware
	SOAK_TRANSACTIONS=$(SOAK_TRANSACTIONS) $(CARGO) test --release -p avr-modbus-slave --test sim_soak -- --nocapture
