# Two commands do everything: `make demo` and `make test`. Both set up first.
SHELL := /bin/bash
.SHELLFLAGS := -euo pipefail -c
.DEFAULT_GOAL := help

CARGO := .ci/cargo
comma := ,
# Under make a test whose firmware, fixture or bootloader is missing fails (a plain `cargo
# test` skips it with what to run: tools/sim/src/built.rs). CI=true does the same.
export AVR_MODBUS_REQUIRE_FIRMWARE := 1
# The CPU clock is the build's environment (build.rs): 16 MHz everywhere but where a target
# names the 8 MHz boards' EIGHT_MHZ, whatever the shell that runs make says.
unexport AVR_CPU_FREQUENCY_HZ
EIGHT_MHZ := AVR_CPU_FREQUENCY_HZ=8000000
# Every example but the gateway and two_lines, which need a Mega's two USARTs (their
# required-features keep them out of the Uno's build of every example), and the TCP servers (those
# whose required-features in Cargo.toml name tcp), which need a shield (make chips builds them:
# make tcp-firmware).
TCP_EXAMPLES := $(shell awk '/^name = /{ name = $$3 } /^required-features = .*"tcp"/{ gsub(/"/, "", name); print name }' Cargo.toml)
MEGA_EXAMPLES := gateway two_lines
EXAMPLES := $(filter-out $(MEGA_EXAMPLES) $(TCP_EXAMPLES),$(patsubst examples/%.rs,%,$(wildcard examples/*.rs)))
FIRMWARE_DIR := target/avr-atmega328p/release/examples
FIRMWARE := $(addprefix $(FIRMWARE_DIR)/,$(addsuffix .elf,$(EXAMPLES)))

.PHONY: demo-plant tcp-firmware capture-firmware soak-tcp sim-test-uno sim-test-chips clippy-tools help setup bootloaders virtual-boards demo-firmware demos demo-lab demo-tcp firmware firmware-uno chips virtual-test matrix-host matrix-avr docs-host docs-avr fixtures package readme sizes lint fmt-check clippy unit check matrix docs sim-test test demo serve interop bench bench-features fuzz soak mutants

help:
	@echo "Two commands do everything: make demo and make test. Every target:"
	@echo "  make demo        - flash the Uno slave with cargo run (ravedude, avrdude, optiboot) on a virtual Uno, and poll it (BOARD=mega2560: a Mega 2560)"
	@echo "  make demo-lab    - the lab's control application: a master and two slaves on a virtual RS-485 line"
	@echo "  make demos       - make demo for the Uno and the Mega 2560, then make demo-lab (what make test runs, with make demo-tcp)"
	@echo "  make demo-tcp    - the TCP server on a virtual Uno with a virtual Ethernet shield, polled over Modbus TCP by mbpoll (SHIELD=w5500)"
	@echo "  make demo-plant  - a plant: a SCADA over Modbus TCP, a virtual Uno gateway with its shield, the lab's two boards and pymodbus on the RS-485 line (ARGS=--serve keeps it running)"
	@echo "  make serve       - keep a virtual board running for QModMaster or any master (EXAMPLE=uno_slave, BOARD=mega2560 USART=1; SHIELD=w5100|w5500 TCP_PORT=1502: Modbus TCP on 127.0.0.1)"
	@echo "  make test        - make check, matrix, docs, firmware, fixtures, sim-test, interop, demos, demo-tcp, demo-plant, virtual-test, in three lanes (.ci/test; what CI runs)"
	@echo "  make check       - the edit loop: make fmt-check, make clippy-tools and make unit (lints as it builds)"
	@echo "  make setup       - install and check the toolchain, simulator, masters and flashing tools"
	@echo "  make firmware    - make firmware-uno, then make chips"
	@echo "  make firmware-uno - every example for the Uno ($(FIRMWARE_DIR)), with sizes and the firmware check"
	@echo "  make chips       - the examples for the other chips and USARTs, and the Uno's that make bench sizes, as the avr-hal template builds them (target/chips)"
	@echo "  make capture-firmware - the Uno's capture-line builds as make chips builds them: boards and master_boards on pins 8/9, the gateway (make interop runs them)"
	@echo "  make tcp-firmware - the TCP servers as make chips builds them: tcp_server (TCP_BUILDS; and with Modbus UDP, W5100 and W5500), libmodbus_map (libmodbus's unit-test map, W5100)"
	@echo "  make sizes       - flash and RAM of every firmware (make firmware prints them)"
	@echo "  make fixtures    - a user's firmware in the template's form for three boards, make package and make readme"
	@echo "  make package     - the crate as it would be published, built into the Uno fixture"
	@echo "  make readme      - the README's two main.rs and the TCP guide's, taken from them and built for the Uno as the template builds them, against a stand-in arduino-hal"
	@echo "  make virtual-boards - the virtual Uno and the virtual line, built (release)"
	@echo "  make demo-firmware - the demos' firmware (demo/uno, demo/mega2560), built as make demo builds it"
	@echo "  make bootloaders - the virtual boards' bootloaders (optiboot, stk500v2)"
	@echo "  make lint        - make fmt-check, make clippy, make matrix and make docs, and this list checked against the targets"
	@echo "  make fmt-check   - cargo fmt --check"
	@echo "  make clippy      - clippy with -D warnings on the host, check builds: make clippy-tools, the crate under TEST_FEATURE_SETS"
	@echo "  make clippy-tools - clippy with -D warnings on the tools (simulator, virtual Uno, bench), tests included"
	@echo "  make matrix      - the check-only feature matrix: the library linted under each feature and combination, host and Uno; the examples"
	@echo "  make matrix-host - make matrix's host half"
	@echo "  make matrix-avr  - make matrix's Uno half and the examples"
	@echo "  make docs-host   - the host's docs and docs.rs's"
	@echo "  make docs-avr    - the Uno's docs"
	@echo "  make docs        - the API docs, warnings denied, for the host and the AVR, then as docs.rs builds them (.ci/docsrs)"
	@echo "  make unit        - the host tests (library, doctests, tests/*.rs but the simulator's) under TEST_FEATURE_SETS, linted"
	@echo "  make sim-test    - the simulator tests once each, the simulator's and the bench's tests (after the firmware, fixtures, bootloaders)"
	@echo "  make sim-test-uno - make sim-test's tests that run only the Uno's firmware"
	@echo "  make sim-test-chips - make sim-test's tests that run other chips' firmware or the fixtures (SIM_CHIPS), the tools' tests"
	@echo "  make virtual-test - the virtual Uno's and virtual line's tests (boards paced to real time on ptys)"
	@echo "  make interop     - mbpoll, pymodbus, minimalmodbus and libmodbus against the firmware on virtual boards, serial and TCP, and through the TCP gateway"
	@echo "  make bench       - size targets (met or not; flash as the avr-hal template builds), flash, RAM, stack, interrupt cycles, turnaround -> bench/results.md"
	@echo "  make bench-features - minimal built with each optional feature, for make bench"
	@echo "  make fuzz        - coverage-guided fuzz targets (FUZZ_SECONDS each), then a long property run"
	@echo "  make mutants     - cargo-mutants over the protocol core, a quarter of its mutants (~1 h on 2 cores; MUTANTS_SHARD) -> bench/results.md"
	@echo "  make soak        - 100000 mixed transactions against uno_slave in simavr (~15 min; SOAK_TRANSACTIONS)"
	@echo "  make soak-tcp    - 10000 one-shot mbpoll -m tcp connections to tcp_server on a virtual Uno with a W5100 (SOAK_TCP_CONNECTIONS), then 2 h of DHCP renewals and rebindings in the simulator (SOAK_DHCP_SECONDS)"
	@echo "  make help        - this list"

setup:
	@.ci/setup

# The master's examples (feature master).
MASTER_EXAMPLES := plc_poller master_mirror poll_holding poll_four lab_control master_boards

# Every firmware: the Uno's examples (firmware-uno), then the other chips' (chips).
firmware: firmware-uno chips

# The examples that keep the clock (feature millis) are a build of their own, so that the
# others carry no clock.
firmware-uno: setup
	$(CARGO) uno --examples --features examples
	$(CARGO) uno --example uno_slave --example dip_switch --example boards --example call_loop --features examples,millis
	$(CARGO) uno --example ascii --features examples,ascii
	$(CARGO) uno --example sixteen_each_capture --features examples,capture-line
	$(CARGO) uno --example configurable --features examples,eeprom-settings,ascii,device-id,reply-delay,$(OPTIONAL)
	$(CARGO) uno $(addprefix --example ,$(MASTER_EXAMPLES)) --features examples,master
	$(CARGO) uno --example ascii_master --features examples,master,ascii
	$(CARGO) uno --example slow_master --features examples,reply-delay
	$(CARGO) uno --example panel_setpoint --features examples,write-protect
	$(CARGO) uno --example libmodbus_map_rtu --features examples,extra-fc,diagnostics
	@.ci/sizes $(FIRMWARE)
	@.ci/firmware-check $(FIRMWARE)

# examples/boards.rs and examples/master_boards.rs on the other chips, as the avr-hal template
# builds (.ci/chip-build: target avr-none, -C target-cpu=CHIP), on each of their USARTs, in one
# build each with feature master (boards is byte for byte the one built with millis alone):
# boards into target/chips/CHIP/avr-none/release/examples/ (the board's pins 0/1: USART0, the
# 32U4's USART1) or target/chips/CHIP-usartN/… for the Mega's other USARTs, master_boards
# into target/chips/CHIP[-usartN]-master/…. Cargo keeps each CHIP's build apart in target/
# (its flags are part of it) and shares the host tools; a USART is a cfg of this crate
# (build.rs), so only the crate rebuilds for it. Then boards once more with the line settings
# in EEPROM and ASCII (target/chips/CHIP[-usartN]-settings/…) for the Mega's Serial1 and the
# Leonardo. The Uno's examples that make bench sizes, the contract (sixteen_each,
# sixteen_each_bank) and minimal among them, for the ATmega328P the same way, into
# target/chips/atmega328p/… (those with feature millis into target/chips/atmega328p-millis/…,
# the master's beside master_boards in target/chips/atmega328p-master/…): the sizes a user of
# the template sees, which make bench leads with; the gateway (slave on USART0, master on
# USART1) and two_lines (two slaves, one model) for the ATmega2560 into
# target/chips/atmega2560-gateway/ and target/chips/atmega2560-two-lines/; and boards and
# master_boards for an 8 MHz ATmega328P and ATmega32U4 (AVR_CPU_FREQUENCY_HZ=8000000, the
# Pro Mini and Pro Micro 3.3 V) into target/chips/CHIP-8mhz/ and target/chips/CHIP-8mhz-master/:
# the clock, too, is read by build.rs, so only the crate and the examples rebuild for it.
# The serial line on a timer's input capture (feature capture-line, AVR_MODBUS_EXAMPLE_USART=
# capture): boards and master_boards on the Leonardo's 13/5 and the Mega's 48/46 into
# target/chips/CHIP-capture/, for the Uno the contract on pins 8/9 (sixteen_each_capture) into
# target/chips/atmega328p-capture-uno/, boards with the line settings in EEPROM and ASCII on
# pins 8/9 into target/chips/atmega328p-capture-settings/ and boards on pins 8/9 of an 8 MHz
# ATmega328P into target/chips/atmega328p-8mhz-capture/; the Uno's others (boards and
# master_boards, the gateway) are make capture-firmware's.
# The chips and USARTs, from chips/chips.txt: CHIP: (the board's pins 0/1), then CHIP:N for
# each of its other USARTs.
CHIP_BUILDS := $(shell awk '$$1 == "chip" { chip = $$2; print chip ":" } \
	$$1 == "usart" && $$7 != "pins-0/1" { print chip ":" substr($$2, 6) }' chips/chips.txt)
TEMPLATE_EXAMPLES := minimal busy_loop lab_lights sixteen_each sixteen_each_bank
TEMPLATE_MILLIS_EXAMPLES := uno_slave dip_switch
TEMPLATE_MASTER_EXAMPLES := poll_holding poll_four master_mirror plc_poller
# .ci/chip-build into DIR-master, then boards moved from there to DIR.
boards_and_master = .ci/chip-build $(1) "$(2)" $(3)-master $(4) $(5) && mkdir -p target/chips/$(3)/avr-none/release/examples && mv target/chips/$(3)-master/avr-none/release/examples/boards.elf target/chips/$(3)/avr-none/release/examples/
chips: setup tcp-firmware capture-firmware
	@for build in $(CHIP_BUILDS); do \
		chip=$${build%%:*}; usart=$${build##*:}; dir=$$chip$${usart:+-usart$$usart}; \
		if [ "$$build" = atmega328p: ]; then \
			.ci/chip-build $$chip "" $$dir-master examples,master master_boards $(TEMPLATE_MASTER_EXAMPLES) || exit 1; \
		else \
			$(call boards_and_master,$$chip,$$usart,$$dir,examples$(comma)master,boards master_boards) || exit 1; \
		fi; \
	done
	@for build in atmega2560:1 atmega32u4:; do \
		chip=$${build%%:*}; usart=$${build##*:}; \
		.ci/chip-build $$chip "$$usart" $$chip$${usart:+-usart$$usart}-settings \
			examples,millis,eeprom-settings,ascii boards || exit 1; \
	done
	@.ci/chip-build atmega328p "" atmega328p examples $(TEMPLATE_EXAMPLES)
	@.ci/chip-build atmega328p "" atmega328p-millis examples,millis $(TEMPLATE_MILLIS_EXAMPLES)
	@.ci/chip-build atmega2560 "" atmega2560-gateway examples,master gateway
	@.ci/chip-build atmega2560 "" atmega2560-two-lines examples,millis two_lines
	@for chip in atmega32u4 atmega2560; do \
		.ci/chip-build $$chip capture $$chip-capture examples,capture-line,master boards master_boards || exit 1; \
	done
	@.ci/chip-build atmega328p "" atmega328p-capture-uno examples,capture-line sixteen_each_capture
	@.ci/chip-build atmega328p capture atmega328p-capture-settings examples,capture-line,millis,eeprom-settings,ascii boards
	@export $(EIGHT_MHZ); .ci/chip-build atmega328p capture atmega328p-8mhz-capture examples,capture-line,master boards
	@export $(EIGHT_MHZ); for chip in atmega328p atmega32u4; do \
		$(call boards_and_master,$$chip,,$$chip-8mhz,examples$(comma)master,boards master_boards) || exit 1; \
	done
	@.ci/sizes target/chips/*/avr-none/release/examples/*.elf
	@.ci/firmware-check target/chips/*/avr-none/release/examples/*.elf

sizes: firmware

# The TCP server (examples/tcp_server.rs) as make chips builds it, CHIP:SHIELD, into
# target/chips/CHIP-SHIELD/: the Uno with either chip, polled or with the INT line on pin 2,
# the Mega 2560 and the Leonardo with a W5500. Then the TCP contract (sixteen_each_tcp) and
# the firmware with both TCP and RTU (tcp_rtu: one model on both ports; tcp_rtu_copy: two maps
# and a copy, its control in tests/sim_shared_model.rs) into target/chips/atmega328p-tcp/, the contract
# with RTU over TCP on socket 3, port 5020 (feature rtu-over-tcp: tests/sim_rtu_over_tcp.rs,
# interop_tcp's pymodbus RTU framer) into target/chips/atmega328p-tcp-rtu/, the contract with an
# allow-list whose second client may only read (feature write-protect: tests/sim_read_only.rs,
# interop_tcp's read-only client) into target/chips/atmega328p-tcp-read-only/, and
# examples/libmodbus_map.rs (libmodbus's unit-test map on a W5100, with the FC 17, 22 and 23
# its unit-test-client uses) into target/chips/atmega328p-w5100-libmodbus/: make interop runs
# tcp_server and libmodbus_map on the virtual shields (tools/virtual-uno/tests/interop_tcp.rs).
# The TCP to RTU gateway (tcp_gateway, W5100, USART0) into target/chips/atmega328p-tcp-gateway/,
# and with the INT line on pin 2 into target/chips/atmega328p-tcp-gateway-int/, and with RTU
# over TCP on socket 3, port 5020, into target/chips/atmega328p-tcp-gateway-rtu/.
# The TCP client (features tcp and master): examples/tcp_poll.rs (the TCP masters' size
# figure) and examples/tcp_client_check.rs (what tests/sim_tcp_client.rs and
# tools/virtual-uno/tests/interop_tcp_client.rs run) into target/chips/atmega328p-tcp-client/,
# tcp_client_check for the W5500 into target/chips/atmega328p-tcp-client-w5500/.
TCP_BUILDS := atmega328p:w5100 atmega328p:w5500 atmega328p:w5100-int atmega328p:w5500-int atmega2560:w5500 atmega32u4:w5500
TCP_FIRMWARE := $(foreach b,$(TCP_BUILDS),target/chips/$(subst :,-,$(b))/avr-none/release/examples/tcp_server.elf) \
	target/chips/atmega328p-tcp/avr-none/release/examples/sixteen_each_tcp.elf \
	target/chips/atmega328p-tcp/avr-none/release/examples/tcp_rtu.elf \
	target/chips/atmega328p-tcp/avr-none/release/examples/tcp_rtu_copy.elf \
	target/chips/atmega328p-tcp-rtu/avr-none/release/examples/sixteen_each_tcp.elf \
	target/chips/atmega328p-tcp-dhcp/avr-none/release/examples/sixteen_each_tcp.elf \
	target/chips/atmega328p-tcp-read-only/avr-none/release/examples/sixteen_each_tcp.elf \
	target/chips/atmega328p-w5100-libmodbus/avr-none/release/examples/libmodbus_map.elf \
	target/chips/atmega328p-tcp-gateway/avr-none/release/examples/tcp_gateway.elf \
	target/chips/atmega328p-tcp-gateway-int/avr-none/release/examples/tcp_gateway.elf \
	target/chips/atmega328p-tcp-gateway-rtu/avr-none/release/examples/tcp_gateway.elf \
	target/chips/atmega328p-tcp-client/avr-none/release/examples/tcp_poll.elf \
	target/chips/atmega328p-tcp-client/avr-none/release/examples/tcp_client_check.elf \
	target/chips/atmega328p-tcp-client-w5500/avr-none/release/examples/tcp_client_check.elf \
	$(foreach s,w5100 w5500,target/chips/atmega328p-$(s)-udp/avr-none/release/examples/tcp_server.elf) \
	target/chips/atmega328p-tcp-udp/avr-none/release/examples/sixteen_each_tcp.elf \
	target/chips/atmega328p-tcp-gateway-udp/avr-none/release/examples/tcp_gateway.elf
tcp-firmware: setup
	@for build in $(TCP_BUILDS); do \
		chip=$${build%%:*}; shield=$${build##*:}; \
		AVR_MODBUS_EXAMPLE_SHIELD=$$shield .ci/chip-build $$chip "" $$chip-$$shield examples,tcp,millis tcp_server || exit 1; \
	done
	@.ci/chip-build atmega328p "" atmega328p-tcp examples,tcp sixteen_each_tcp tcp_rtu tcp_rtu_copy
	@.ci/chip-build atmega328p "" atmega328p-tcp-rtu examples,tcp,rtu-over-tcp sixteen_each_tcp
	@.ci/chip-build atmega328p "" atmega328p-tcp-dhcp examples,tcp,dhcp sixteen_each_tcp
	@.ci/chip-build atmega328p "" atmega328p-tcp-read-only examples,tcp,write-protect sixteen_each_tcp
	@.ci/chip-build atmega328p "" atmega328p-w5100-libmodbus examples,tcp,extra-fc,diagnostics libmodbus_map
	@.ci/chip-build atmega328p "" atmega328p-tcp-gateway examples,tcp,master tcp_gateway
	@AVR_MODBUS_EXAMPLE_SHIELD=w5100-int .ci/chip-build atmega328p "" atmega328p-tcp-gateway-int examples,tcp,master tcp_gateway
	@.ci/chip-build atmega328p "" atmega328p-tcp-gateway-rtu examples,tcp,master,rtu-over-tcp tcp_gateway
	@.ci/chip-build atmega328p "" atmega328p-tcp-client examples,tcp,master tcp_poll tcp_client_check
	@AVR_MODBUS_EXAMPLE_SHIELD=w5500 .ci/chip-build atmega328p "" atmega328p-tcp-client-w5500 examples,tcp,master \
		tcp_client_check
	@for shield in w5100 w5500; do \
		AVR_MODBUS_EXAMPLE_SHIELD=$$shield .ci/chip-build atmega328p "" atmega328p-$$shield-udp examples,tcp,millis,udp \
			tcp_server || exit 1; \
	done
	@.ci/chip-build atmega328p "" atmega328p-tcp-udp examples,tcp,udp sixteen_each_tcp
	@.ci/chip-build atmega328p "" atmega328p-tcp-gateway-udp examples,tcp,master,udp tcp_gateway
	@.ci/sizes $(TCP_FIRMWARE)
	@.ci/firmware-check $(TCP_FIRMWARE)

# The Uno's serial line on Timer1's input capture (feature capture-line), which make interop
# runs on the virtual Uno's pins 8/9: boards and master_boards (AVR_MODBUS_EXAMPLE_USART=capture)
# into target/chips/atmega328p-capture/, and the gateway (its master on pins 8/9, its slave on
# USART0, pins 0/1) into target/chips/atmega328p-capture-gateway/.
capture-firmware: setup
	@.ci/chip-build atmega328p capture atmega328p-capture examples,capture-line,master boards master_boards
	@.ci/chip-build atmega328p "" atmega328p-capture-gateway examples,capture-line,master gateway

# A user's firmware in the avr-hal template's form (fixtures/), outside the workspace, built
# against avr-device 0.8.1 (arduino-hal's) and 0.9, for three of the template's boards as it
# builds them (its board's -C target-cpu and HAL feature): tests/sim_template.rs runs each
# ELF, target/fixtures/BOARD/avr-none/release/template-avr-device-0N.elf. They build in the
# workspace's target directory, sharing its core and host tools with make chips: the board's
# -C target-cpu goes in CARGO_TARGET_AVR_NONE_RUSTFLAGS as .ci/chip-build gives it (passed
# as build.rustflags, the same flags name a build of core cargo keeps apart). Then
# fixtures/r0-clobber, the reproducer of the AVR backend's r0 clobber that
# tools/sim/tests/miscompile.rs runs and checks (target/fixtures/r0-clobber/…), make package
# and make readme.
FIXTURES := $(wildcard fixtures/template-*)
FIXTURE_BOARDS := uno:atmega328p mega2560:atmega2560 leonardo:atmega32u4
fixtures: setup
	@for f in $(FIXTURES); do \
		for board in $(FIXTURE_BOARDS); do \
			echo "fixture: $$f, $${board%%:*}"; \
			(cd $$f && CARGO_TARGET_AVR_NONE_RUSTFLAGS="-C target-cpu=$${board##*:}" ../../.ci/cargo build \
				--release --locked --features $${board%%:*} --target-dir ../../target); \
			elf=$$(sed -n 's/^name = "\(template-.*\)"$$/\1/p' $$f/Cargo.toml | head -n 1).elf; \
			mkdir -p target/fixtures/$${board%%:*}/avr-none/release; \
			cp target/avr-none/release/$$elf target/fixtures/$${board%%:*}/avr-none/release/; \
		done; \
	done
	@echo "fixture: fixtures/r0-clobber, uno"
	cd fixtures/r0-clobber && CARGO_TARGET_AVR_NONE_RUSTFLAGS="-C target-cpu=atmega328p" \
		../../.ci/cargo build --release --locked --target-dir ../../target
	@mkdir -p target/fixtures/r0-clobber/avr-none/release
	@cp target/avr-none/release/r0-clobber-stack.elf target/avr-none/release/r0-clobber-static.elf \
		target/fixtures/r0-clobber/avr-none/release/
	@$(MAKE) --no-print-directory package
	@$(MAKE) --no-print-directory readme
	@.ci/sizes target/fixtures/*/avr-none/release/template-*.elf
	@.ci/firmware-check --r0-only target/fixtures/*/avr-none/release/template-*.elf

# The crate as it would be published (`cargo package`, no upload), unpacked, and the Uno
# fixture built against it instead of this tree (target/fixtures/packaged/…): a file the
# package leaves out fails here.
PACKAGE_FIXTURE := target/package-fixture
package: setup
	$(CARGO) package --allow-dirty -p avr-modbus 2>&1 | grep -v '^warning: ignoring \(test\|example\)'
	@rm -rf $(PACKAGE_FIXTURE) && mkdir -p $(PACKAGE_FIXTURE)
	@cp -r fixtures/template-avr-device-0.8/. $(PACKAGE_FIXTURE)/
	@version=$$(sed -n 's/^version = "\(.*\)"$$/\1/p' Cargo.toml | head -n 1); \
		sed -i "s|path = \"../..\"|path = \"../package/avr-modbus-$$version\"|" $(PACKAGE_FIXTURE)/Cargo.toml; \
		grep -q "package/avr-modbus-$$version" $(PACKAGE_FIXTURE)/Cargo.toml
	cd $(PACKAGE_FIXTURE) && CARGO_TARGET_AVR_NONE_RUSTFLAGS="-C target-cpu=atmega328p" \
		../../.ci/cargo build --release --locked --features uno --target-dir ..
	@mkdir -p target/fixtures/packaged/avr-none/release
	@cp target/avr-none/release/template-avr-device-08.elf target/fixtures/packaged/avr-none/release/

# The README's two main.rs, the slave's and the master's, so that they cannot drift from
# the API: fixtures/readme/blocks writes them from the README into fixtures/readme/src/, and
# each is built for the Uno as a template project builds it, with the crate's features its
# README line names (millis; master), against fixtures/readme/arduino-hal, a stand-in for the
# git-only arduino-hal (its names, its pins' types, the Uno only) ->
# target/fixtures/readme/avr-none/release/readme-{slave,master}.elf. A README block that stops
# compiling fails here. Their sizes are the stand-in's, not arduino-hal's: on the same README
# and crate (46fb4c2) 2 B (slave) and 4 B (master) of flash under arduino-hal's, RAM the same.
README_FIRMWARE := slave master tcp gateway tcp-client
readme: setup
	@echo "fixture: fixtures/readme, uno"
	fixtures/readme/blocks
	@for role in $(README_FIRMWARE); do \
		(cd fixtures/readme && CARGO_TARGET_AVR_NONE_RUSTFLAGS="-C target-cpu=atmega328p" ../../.ci/cargo build \
			--release --locked --features $$role --bin readme-$$role --target-dir ../../target) || exit 1; \
		mkdir -p target/fixtures/readme/avr-none/release; \
		cp target/avr-none/release/readme-$$role.elf target/fixtures/readme/avr-none/release/; \
	done
	@.ci/sizes $(patsubst %,target/fixtures/readme/avr-none/release/readme-%.elf,$(README_FIRMWARE))
	@.ci/firmware-check --r0-only $(patsubst %,target/fixtures/readme/avr-none/release/readme-%.elf,$(README_FIRMWARE))
	@fixtures/readme/figures

fmt-check: setup
	$(CARGO) fmt --all --check

# The optional function codes, checked and tested as a second build.
OPTIONAL := diagnostics,extra-fc,write-protect
# Every feature (all add) but examples, which builds this repository's firmware.
ALL_FEATURES := ufmt,millis,master,capture-line,reply-delay,write-protect,extra-fc,diagnostics,eeprom-settings,ascii,device-id,tcp,rtu-over-tcp,udp,dhcp

# The host's lints, tests included, check builds only: the tools (clippy-tools) and the crate's
# library and test targets as make unit and make sim-test build them (under
# TEST_FEATURE_SETS: a simulator test under the first set, every other under each set that
# tells its cases apart). make unit and make sim-test lint what they build as they build it;
# every other feature set of the library is linted by make matrix.
clippy: clippy-tools
	.ci/host-test clippy $(TEST_FEATURE_SETS)

# The tools (the simulator, the virtual Uno, the bench), their tests included.
clippy-tools: setup
	$(CARGO) clippy --workspace --exclude avr-modbus --all-targets -- -D warnings
	$(CARGO) clippy -p virtual-uno --test interop --test interop_tcp --test interop_gateway --test interop_tcp_client --test interop_udp --test interop_tcp_health --test interop_two_ports --test interop_capture -- -D warnings # test = false: not in --all-targets

# The feature sets the crate's host tests run under (.ci/host-test: a test target runs under
# each set that has the features it declares in Cargo.toml and gives the features its source
# names values no earlier set gave them; the library and its doctests under every set; a
# simulator test once, under the first set that has its features). A test with a new
# combination of features needs its set here; no test is named. A set may start with the
# build's environment, NAME=VALUE: (the 8 MHz clock's: the tests that name the clock run
# under it again). tcp,master: the TCP server and gateway as a firmware without feature udp
# builds them (all has udp).
TEST_FEATURE_SETS := all default $(EIGHT_MHZ):ascii master $(OPTIONAL),eeprom-settings eeprom-settings,ascii eeprom-settings,reply-delay \
	tcp,master

# The host tests (no firmware needed): the library, its doctests and every tests/*.rs but the
# simulator's, under TEST_FEATURE_SETS, built with clippy as the compiler (warnings denied).
unit: setup
	$(LINTED) .ci/host-test host $(TEST_FEATURE_SETS)

# How make unit and make sim-test build the tests: clippy as the compiler, warnings denied, so
# that the build that runs the tests is also their lint (and, the flags being the same,
# uno-sim, which the crate's tests use, is built once for both).
LINTED := RUSTC_WORKSPACE_WRAPPER=clippy-driver RUSTFLAGS="-D warnings"

# The edit loop: format, the tools' lints, and the host tests linted as they build.
check: fmt-check clippy-tools unit

# Every single feature and the combinations users build, compiled and linted without
# building a test: the library for the host and for the Uno (.ci/feature-matrix; at 8 MHz too,
# a combination that starts with EIGHT_MHZ:), then the Uno's examples with every feature and
# the Mega's gateway.
FEATURE_COMBOS := $(ALL_FEATURES) $(EIGHT_MHZ):$(ALL_FEATURES) master,ascii master,ufmt eeprom-settings,ascii \
	eeprom-settings,reply-delay,ascii $(EIGHT_MHZ):master $(EIGHT_MHZ):ascii,millis tcp,master tcp,udp dhcp
matrix: matrix-host matrix-avr
matrix-host: setup
	.ci/feature-matrix host $(FEATURE_COMBOS)
matrix-avr: setup
	.ci/feature-matrix avr $(FEATURE_COMBOS)
	$(CARGO) uno-clippy $(addprefix --example ,$(EXAMPLES) $(TCP_EXAMPLES)) --features examples,$(ALL_FEATURES) -- -D warnings
	CARGO_TARGET_AVR_NONE_RUSTFLAGS="-C target-cpu=atmega2560" $(CARGO) clippy --release -Zbuild-std=core --target avr-none \
		--example gateway --features examples,master -- -D warnings
	CARGO_TARGET_AVR_NONE_RUSTFLAGS="-C target-cpu=atmega2560" $(CARGO) clippy --release -Zbuild-std=core --target avr-none \
		--example two_lines --features examples,millis -- -D warnings

# The API docs, warnings denied: for the host (no AVR layer) and as docs.rs builds them (the
# host, `--cfg docsrs`: the AVR layer too), checked against the README's API tables; for the Uno.
docs: docs-host docs-avr
docs-host: setup
	RUSTDOCFLAGS="-D warnings" $(CARGO) doc --no-deps -p avr-modbus --features $(ALL_FEATURES)
	.ci/docsrs
docs-avr: setup
	RUSTDOCFLAGS="-D warnings -C target-cpu=atmega328p" $(CARGO) doc --no-deps -p avr-modbus --release \
		-Zjson-target-spec -Zbuild-std=core --target avr-atmega328p.json --features $(ALL_FEATURES)

lint: fmt-check clippy matrix docs
	@.ci/help-check

# What runs the firmware in simulated time (cycles, never the wall clock): each simulator test
# once, and the simulator's and the bench's own tests; after the firmware, fixtures and
# bootloaders. In two halves, so that make test runs the first while the other chips build.
sim-test: sim-test-uno sim-test-chips

# The simulator tests that run what make chips or make fixtures build; every other needs only
# the Uno's firmware and the bootloaders. (One missing here fails under make test: its ELF is
# not built yet when sim-test-uno runs it.)
SIM_CHIPS := sim_8mhz,sim_capture,sim_boards,sim_boards_settings,sim_dhcp,sim_gateway,sim_read_only,sim_rtu_over_tcp,sim_shared_model,sim_tcp,sim_tcp_client,sim_tcp_gateway,sim_tcp_health,sim_template,sim_two_lines

# Every simulator test built, those that need only the Uno's firmware run; the tools' tests
# built (make sim-test-chips runs them).
sim-test-uno: setup firmware-uno bootloaders
	$(LINTED) .ci/host-test --skip=$(SIM_CHIPS) sim $(TEST_FEATURE_SETS)
	$(LINTED) $(CARGO) test -p uno-sim -p bench --no-run

# The simulator tests of SIM_CHIPS, and the simulator's and the bench's own tests.
sim-test-chips: setup firmware fixtures bootloaders
	$(LINTED) .ci/host-test --only=$(SIM_CHIPS) sim $(TEST_FEATURE_SETS)
	$(LINTED) $(CARGO) test -p uno-sim -p bench

# The virtual Uno's and the virtual line's own tests: boards paced to real time on ptys.
virtual-test: setup firmware bootloaders
	$(CARGO) test -p virtual-uno

# What the README's second command and CI run: everything above, in three lanes at once
# (.ci/test): the host's lints and tests, the AVR builds, and what runs in real time (interop,
# the demos, the virtual boards' tests) as soon as its firmware is built.
test:
	@.ci/test

# The virtual Uno and the virtual line (release), which make interop, make demos and make
# virtual-test run.
virtual-boards: setup
	$(CARGO) build --release -p virtual-uno --bins

# The demos' firmware (demo/uno, demo/mega2560) built as demo/demo.sh's `cargo run` builds it,
# so that make demos starts with nothing left to build.
demo-firmware: setup
	@for board in uno:atmega328p mega2560:atmega2560; do \
		(cd demo/$${board%%:*} && CARGO_TARGET_AVR_NONE_RUSTFLAGS="-C target-cpu=$${board##*:}" \
			../../.ci/cargo build --release --locked --target-dir ../../target) || exit 1; \
	done

# make demo for both boards, as a user runs it: flashed with cargo run through the
# bootloader, then polled; and make demo-lab. (make test runs make demo-tcp too, once make
# chips has built its firmware.)
demos: setup bootloaders
	demo/demo.sh uno
	demo/demo.sh mega2560
	demo/lab.sh

# The TCP server (examples/tcp_server.rs) on a virtual Uno with a virtual Ethernet shield,
# polled over Modbus TCP by mbpoll (SHIELD=w5500 for the W5500).
demo-tcp: setup tcp-firmware
	demo/tcp.sh $(or $(SHIELD),w5100)

# A whole plant on the virtual network (demo/plant.sh): mbpoll -m tcp as the SCADA, through
# examples/tcp_gateway.rs on a virtual Uno with a virtual W5100 (its port 502 on
# 127.0.0.1:TCP_PORT), to the lab's button box and light tower (examples/lab_lights.rs twice)
# and pymodbus's serial server (unit 3, demo/plant_slave.py) on one virtual RS-485 line; every
# frame and every TCP request and answer printed. ARGS=--serve keeps the plant running for
# QModMaster after the checks.
demo-plant: setup firmware-uno tcp-firmware
	TCP_PORT=$(TCP_PORT) demo/plant.sh $(ARGS)

# The lab's control application on a virtual RS-485 line (tools/virtual-uno's virtual-line):
# examples/lab_control.rs (the master) and examples/lab_lights.rs twice (the button box and
# the light tower); START and STOP pressed with pin commands, every frame printed with its
# sender, the lamps followed.
demo-lab: setup firmware
	demo/lab.sh

EXAMPLE ?= uno_slave

# The boards' bootloaders for the virtual boards (target/bootloaders): the Uno's optiboot
# built from Debian's arduino-core-avr source, the Mega 2560's stk500v2 as it ships.
bootloaders: setup
	@.ci/bootloaders

# A virtual Uno (simavr on a pseudo-terminal, optiboot at every reset) flashed with
# `cargo run --release` in demo/uno, the avr-hal template's form (ravedude -> avrdude ->
# the bootloader), then polled by mbpoll. BOARD=mega2560: a virtual Mega 2560, demo/mega2560.
demo: setup bootloaders
	demo/demo.sh $(if $(filter uno,$(BOARD)),uno,$(BOARD))

# Keeps a virtual Uno running for QModMaster or any master: make serve EXAMPLE=NAME ARGS="..."
# Another board: make serve BOARD=mega2560 USART=1 runs examples/boards.rs as make chips built
# it for the board's chip and that USART (default: the board's pins 0/1, USART1 on the 32U4
# boards) on the pty; the Uno's boards run EXAMPLE as make firmware built it.
#
# An Ethernet shield: make serve EXAMPLE=NAME SHIELD=w5100 (or w5500) puts the WIZnet chip on the
# board's SPI port (its chip select on pin 10) and bridges the chip's port 502 to 127.0.0.1:TCP_PORT
# (mbpoll -m tcp -p 1502 127.0.0.1); the serial line stays on the pty. Without SHIELD, no shield.
# EXAMPLE=tcp_server runs the TCP server as make chips built it for the board and the chip
# (on the Uno, Mega 2560 and Leonardo: TCP_BUILDS).
BOARD ?= uno
USART ?=
SHIELD ?=
TCP_PORT ?= 1502
SERVE_CHIP := $(strip \
	$(if $(filter uno nano promini,$(BOARD)),atmega328p) \
	$(if $(filter nano168,$(BOARD)),atmega168) \
	$(if $(filter mega2560,$(BOARD)),atmega2560) \
	$(if $(filter mega1280,$(BOARD)),atmega1280) \
	$(if $(filter leonardo promicro micro,$(BOARD)),atmega32u4))
SERVE_DEFAULT_USART := $(if $(filter atmega32u4,$(SERVE_CHIP)),1,0)
SERVE_USART := $(or $(USART),$(SERVE_DEFAULT_USART))
SERVE_BUILD := $(SERVE_CHIP)$(if $(filter-out $(SERVE_DEFAULT_USART),$(SERVE_USART)),-usart$(SERVE_USART))
SERVE_TCP_SERVER := $(and $(filter tcp_server,$(EXAMPLE)),$(SHIELD))
SERVE_EXAMPLE := $(if $(or $(SERVE_TCP_SERVER),$(filter atmega328p,$(SERVE_CHIP))),$(EXAMPLE),boards)
SERVE_ELF := $(if $(SERVE_TCP_SERVER),target/chips/$(SERVE_CHIP)-$(SHIELD)/avr-none/release/examples,$(if $(filter atmega328p,$(SERVE_CHIP)),$(FIRMWARE_DIR),target/chips/$(SERVE_BUILD)/avr-none/release/examples))/$(SERVE_EXAMPLE).elf

serve: $(if $(and $(filter atmega328p,$(SERVE_CHIP)),$(if $(SERVE_TCP_SERVER),,yes)),firmware,chips)
	@[ -n "$(SERVE_CHIP)" ] || { echo "serve: BOARD=$(BOARD)? one of uno nano promini nano168 mega2560 mega1280 leonardo promicro micro" >&2; exit 2; }
	SERVE_BOARD=$(BOARD) SERVE_CHIP=$(SERVE_CHIP) SERVE_USART=$(SERVE_USART) SERVE_ELF=$(SERVE_ELF) \
		SERVE_SHIELD=$(SHIELD) SERVE_TCP=$(if $(SHIELD),502:$(TCP_PORT)) demo/serve.sh $(SERVE_EXAMPLE) $(ARGS)

# mbpoll, pymodbus, minimalmodbus and libmodbus against the firmware on the virtual Uno, with answer rates;
# then over Modbus TCP on the virtual shields (interop_tcp: mbpoll, pymodbus, a raw socket, libmodbus's
# unit-test-client built under target/libmodbus-tests, TCP_CONNECTIONS one-shot connections, masters at once);
# then through the TCP to RTU gateway on the virtual line (interop_gateway: libmodbus's unit-test-client to
# libmodbus_map_rtu and to libmodbus's own unit-test-server in RTU mode on a pty, mbpoll and pymodbus to
# pymodbus's serial server, a slave switched off, 0A, 0B, clients gone mid-request).
# then the firmware's TCP client against pymodbus's TCP server and libmodbus's unit-test-server (interop_tcp_client);
# then Modbus UDP (feature udp) on the virtual shields (interop_udp: pymodbus's UDP client, clients at once, a raw socket).
# then one model on two ports (interop_two_ports: mbpoll on the serial line and pymodbus over TCP at once, examples/tcp_rtu.rs);
# then the serial line on Timer1's input capture, on the virtual Uno's pins 8/9 (interop_capture: mbpoll and pymodbus against
# boards, the Uno gateway with pymodbus's serial server as its field device).
TCP_CONNECTIONS ?= 100
interop: firmware-uno bootloaders tcp-firmware capture-firmware
	$(CARGO) test -p virtual-uno --test interop -- --nocapture --test-threads=1
	TCP_CONNECTIONS=$(TCP_CONNECTIONS) $(CARGO) test -p virtual-uno --test interop_tcp -- --nocapture --test-threads=1
	$(CARGO) test -p virtual-uno --test interop_gateway -- --nocapture --test-threads=1
	$(CARGO) test -p virtual-uno --test interop_tcp_client -- --nocapture --test-threads=1
	$(CARGO) test -p virtual-uno --test interop_udp -- --nocapture --test-threads=1
	$(CARGO) test -p virtual-uno --test interop_tcp_health -- --nocapture --test-threads=1
	$(CARGO) test -p virtual-uno --test interop_two_ports -- --nocapture --test-threads=1
	$(CARGO) test -p virtual-uno --test interop_capture -- --nocapture --test-threads=1

# SOAK_TCP_CONNECTIONS one-shot `mbpoll -m tcp -1` connections to tcp_server (W5100) on the virtual
# Uno, each answered, none refused (~10 min for 10000); the firmware's counters read at the end.
SOAK_TCP_CONNECTIONS ?= 10000
# Then SOAK_DHCP_SECONDS of simulated time of tests/sim_dhcp.rs's soak (20 s leases renewed and
# rebound; the simulator runs it about 2.7 times faster than real time: ~45 min for 7200).
SOAK_DHCP_SECONDS ?= 7200
soak-tcp: setup tcp-firmware virtual-boards
	TCP_CONNECTIONS=$(SOAK_TCP_CONNECTIONS) $(CARGO) test -p virtual-uno --test interop_tcp \
		-- --nocapture --exact mbpoll_one_shot_connections_are_all_answered_w5100
	DHCP_SOAK_SECONDS=$(SOAK_DHCP_SECONDS) AVR_MODBUS_REQUIRE_FIRMWARE=1 $(CARGO) test --release --test sim_dhcp \
		-- --ignored --nocapture soak_

bench: setup firmware bench-features
	$(CARGO) run --release -p bench

# minimal built with each optional feature, as `firmware` builds it, into its own target
# directory (firmware's ELF files stay as they are): make bench compares their sizes.
BENCH_FEATURES_DIR := target/bench-features
BENCH_FEATURES := extra-fc diagnostics write-protect device-id millis ascii reply-delay
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
	FUZZ_CASES=$(PROPERTY_CASES) FUZZ_SEED=$${FUZZ_SEED:-$$(date +%s)} $(CARGO) test --release -p avr-modbus \
		--features $(FUZZ_PROPERTY_FEATURES) --test random_frames -- --nocapture
	@echo "fuzz: $(PROPERTY_CASES) cases per property, 4 properties, features $(FUZZ_PROPERTY_FEATURES)"

# Mutation testing of the protocol core (.ci/mutants, .cargo/mutants.toml): a round-robin
# quarter of its mutants, the host tests with every feature that adds; the counts go to
# bench/mutants.md and bench/results.md. Not part of make test: about an hour on 2 cores.
MUTANTS_SHARD ?= 0/4
mutants: setup
	MUTANTS_SHARD=$(MUTANTS_SHARD) .ci/mutants $(ALL_FEATURES)

# Long mixed-request run against uno_slave at 19200 8E1 with a reference model of its bank
# (100000: ~1400 s simulated, ~15 min wall). `make test` runs 2000.
SOAK_TRANSACTIONS ?= 100000
soak: setup firmware
	SOAK_TRANSACTIONS=$(SOAK_TRANSACTIONS) $(CARGO) test --release -p avr-modbus --test sim_soak -- --nocapture
