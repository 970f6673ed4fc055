# Two commands do everything: `make demo` and `make test`. Both set up first.
SHELL := /bin/bash
.SHELLFLAGS := -euo pipefail -c
.DEFAULT_GOAL := help

CARGO := .ci/cargo
EXAMPLES := $(patsubst examples/%.rs,%,$(wildcard examples/*.rs))
FIRMWARE_DIR := target/avr-atmega328p/release/examples
FIRMWARE := $(addprefix $(FIRMWARE_DIR)/,$(addsuffix .elf,$(EXAMPLES)))

.PHONY: help setup firmware sizes lint fmt-check clippy docs host-test test demo bench

help:
	@echo "make demo   - build the Uno slave and poll it on a virtual Uno"
	@echo "make test   - set up, lint, build every firmware, run all tests"
	@echo "make firmware - build every example for the Uno ($(FIRMWARE_DIR))"
	@echo "make bench  - flash, RAM, stack, interrupt cycles, turnaround, throughput -> bench/results.md"

setup:
	@.ci/setup

firmware: setup
	$(CARGO) uno --examples --features rt
	@.ci/sizes $(FIRMWARE)
	@.ci/no-panic $(FIRMWARE)

sizes: firmware

fmt-check: setup
	$(CARGO) fmt --all --check

# The optional function codes, checked and tested as a second build.
OPTIONAL := diagnostics,extra-fc

clippy: setup
	$(CARGO) clippy --workspace --all-targets -- -D warnings
	$(CARGO) clippy -p avr-modbus-slave --all-targets --features $(OPTIONAL) -- -D warnings
	$(CARGO) uno-clippy --examples --features rt -- -D warnings
	$(CARGO) uno-clippy --examples --features rt,$(OPTIONAL) -- -D warnings

docs: setup
	RUSTDOCFLAGS="-D warnings" $(CARGO) doc --no-deps -p avr-modbus-slave --features $(OPTIONAL)

lint: fmt-check clippy docs

host-test: setup firmware
	$(CARGO) test --workspace
	$(CARGO) test -p avr-modbus-slave --features $(OPTIONAL) --lib --test optional_functions --test exceptions --test adu --test framer

test: lint firmware host-test

demo: setup
	@echo "make demo: the virtual Uno is not there yet; 'make test' runs the firmware in simavr."
	@exit 1

bench: setup firmware
	$(CARGO) run --release -p bench
