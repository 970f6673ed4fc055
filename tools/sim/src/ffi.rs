//! Declarations of the C shim in `csrc/shim.c`.

use std::ffi::{c_char, c_int, c_long, c_void};

/// The shim's simulator instance (opaque).
#[repr(C)]
pub(crate) struct Shim {
    _opaque: [u8; 0],
}

/// One transmitted frame, as logged by the shim (`uno_tx_t`).
#[repr(C)]
#[derive(Clone, Copy, Default)]
pub(crate) struct TxRaw {
    pub start: u64,
    pub end: u64,
    pub byte: u8,
}

/// Per-vector interrupt statistics (`uno_isr_t`).
#[repr(C)]
#[derive(Clone, Copy, Default)]
pub(crate) struct IsrRaw {
    pub entries: u64,
    pub cycles: u64,
    pub max_cycles: u64,
}

/// One level change of a logged output pin (`pin_edge_t` in csrc/pins.h).
#[repr(C)]
#[derive(Clone, Copy, Default)]
pub(crate) struct PinEdgeRaw {
    pub cycle: u64,
    pub level: u8,
}

/// simavr's `UART_INPUT_FE`: the frame had a framing error.
pub(crate) const INPUT_FE: u16 = 0x8000;
/// The shim's marker for a parity error.
pub(crate) const INPUT_PE: u16 = 0x4000;

pub(crate) const ERR_PAST: c_int = -1;
pub(crate) const ERR_ORDER: c_int = -2;
pub(crate) const ERR_NOMEM: c_int = -3;
pub(crate) const ERR_ARG: c_int = -4;

/// `uno_run`'s `stop_on_tx` bit of wire `wire` (0: the wire, 1: the second one).
pub(crate) const fn stop_on_tx_of(wire: usize) -> c_int {
    1 << wire
}

/// A part on the SPI bus (`spi_part_fn` in csrc/spi.h): called with each byte the master sent
/// (`event` [`SPI_EVENT_BYTE`]; returns the answer, or -1 for none) and each change of its chip
/// select ([`SPI_EVENT_CS`], `value` the level).
pub(crate) type SpiPartFn = unsafe extern "C" fn(ctx: *mut c_void, event: c_int, value: u8, cycle: u64) -> c_int;
/// A byte went out on the SPI bus.
pub(crate) const SPI_EVENT_BYTE: c_int = 0;
/// The part's chip select changed.
pub(crate) const SPI_EVENT_CS: c_int = 1;
/// The part's INT line: its level (0 low, 1 high), or -1 for none.
pub(crate) const SPI_EVENT_INT: c_int = 2;

extern "C" {
    pub(crate) fn uno_new(
        path: *const c_char,
        mcu: *const c_char,
        usart: c_int,
        base: u16,
        usart2: c_int,
        base2: u16,
        response: u32,
        err: *mut c_char,
        errlen: usize,
    ) -> *mut Shim;
    pub(crate) fn uno_free(s: *mut Shim);
    pub(crate) fn uno_cycle(s: *const Shim) -> u64;
    pub(crate) fn uno_state(s: *const Shim) -> c_int;
    pub(crate) fn uno_run(s: *mut Shim, target: u64, stop_on_tx: c_int) -> c_int;
    pub(crate) fn uno_step(
        s: *mut Shim,
        limit: u64,
        pc: *mut u32,
        vector: *mut c_int,
        entered: *mut c_int,
        response: *mut u64,
    ) -> c_int;
    pub(crate) fn uno_pc(s: *const Shim) -> u32;
    pub(crate) fn uno_sreg(s: *const Shim) -> u8;
    pub(crate) fn uno_running_vector(s: *const Shim) -> c_int;
    pub(crate) fn uno_isr_stats(s: *const Shim, vector: u8, out: *mut IsrRaw);
    pub(crate) fn uno_isr_reset(s: *mut Shim);
    pub(crate) fn uno_rx_push(s: *mut Shim, wire: c_int, at: u64, value: u16) -> c_int;
    pub(crate) fn uno_rx_pending(s: *const Shim, wire: c_int) -> usize;
    pub(crate) fn uno_rx_clear(s: *mut Shim, wire: c_int);
    pub(crate) fn uno_uart_counters(
        s: *const Shim,
        wire: c_int,
        rx_dropped: *mut u64,
        rx_overruns: *mut u64,
        tx_ignored: *mut u64,
    );
    pub(crate) fn uno_tx_len(s: *const Shim, wire: c_int) -> usize;
    pub(crate) fn uno_tx_take(s: *mut Shim, wire: c_int, out: *mut TxRaw, max: usize) -> usize;
    pub(crate) fn uno_tx_busy_until(s: *const Shim, wire: c_int) -> u64;
    pub(crate) fn uno_uart_flags(s: *const Shim) -> u32;
    pub(crate) fn uno_data(s: *mut Shim, len: *mut usize) -> *mut u8;
    pub(crate) fn uno_usart_take(s: *mut Shim, usart: c_int, out: *mut u8, max: usize) -> c_long;
    pub(crate) fn uno_port_regs(
        s: *const Shim,
        port: c_char,
        pin: *mut u16,
        ddr: *mut u16,
        port_reg: *mut u16,
    ) -> c_int;
    pub(crate) fn uno_pin_drive(s: *mut Shim, port: c_char, bit: c_int, level: c_int) -> c_int;
    pub(crate) fn uno_pin_schedule(s: *mut Shim, port: c_char, bit: c_int, at: u64, level: c_int) -> c_int;
    pub(crate) fn uno_pin_scheduled(s: *const Shim) -> usize;
    pub(crate) fn uno_pin_level(s: *const Shim, port: c_char, bit: c_int) -> c_int;
    pub(crate) fn uno_pin_log(s: *mut Shim, port: c_char, bit: c_int, level: *mut c_int) -> c_int;
    pub(crate) fn uno_pin_log_take(s: *mut Shim, port: c_char, bit: c_int, out: *mut PinEdgeRaw, max: usize) -> c_long;
    pub(crate) fn uno_adc_set(s: *mut Shim, channel: c_int, millivolts: u32) -> c_int;
    pub(crate) fn uno_set_aref(s: *mut Shim, millivolts: u32);
    pub(crate) fn uno_flash_size(s: *const Shim) -> u32;
    pub(crate) fn uno_flash_read(s: *const Shim, offset: u32, out: *mut u8, len: u32) -> c_int;
    pub(crate) fn uno_flash_write(s: *mut Shim, offset: u32, bytes: *const u8, len: u32) -> c_int;
    pub(crate) fn uno_set_reset_address(s: *mut Shim, byte_address: u32);
    pub(crate) fn uno_reset(s: *mut Shim, cause: u8);
    pub(crate) fn uno_resets(s: *const Shim, cause: *mut u8) -> u64;
    pub(crate) fn uno_eeprom_size(s: *const Shim) -> u32;
    pub(crate) fn uno_eeprom_read(s: *mut Shim, offset: u32, out: *mut u8, len: u32) -> c_int;
    pub(crate) fn uno_eeprom_write(s: *mut Shim, offset: u32, bytes: *const u8, len: u32) -> c_int;
    pub(crate) fn uno_spi_attach(s: *mut Shim, port: c_char, bit: c_int, f: SpiPartFn, ctx: *mut c_void) -> c_int;
    pub(crate) fn uno_spi_int(s: *mut Shim, port: c_char, bit: c_int) -> c_int;
    pub(crate) fn uno_spi_sync(s: *mut Shim);
}
