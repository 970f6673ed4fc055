//! `memcpy`, `memset` and `memcmp` for the whole firmware, a few instructions each as
//! avr-libc has them (the AVR's `ld`/`st` with post-increment).
//!
//! The compiler calls these for every copy, fill or comparison it doesn't unroll: a frame
//! buffer or a data model moved into its cell, an array zeroed, a write's echo checked.
//! Built as the avr-hal template builds (target `avr-none`, cargo's `build-std`), `core`
//! brings compiler_builtins' own, written for any machine: 156 B for `memset`, 402 B for
//! `memcpy` and 54 B for `memcmp` on the AVR, where avr-libc's are 14, 18 and 26 B. Those
//! are weak symbols, so the strong ones here take their place. A build that links avr-libc
//! (this repository's target) takes these too: the linker pulls an archive member only
//! for a symbol still undefined. `memcmp` is an ordinary call for the compiler, so with
//! LTO it is inlined where it is called; `memcpy` and `memset` are calls it makes itself
//! late, and stay functions.

// Inline `asm!` in ordinary functions, not naked ones: a naked function's body is module
// assembly, which LLVM assembles for the target's default AVR core, where `movw` and
// `ld Z+` don't exist; a function's own assembly knows the `-C target-cpu` it is built for.
// The loops are written in assembly because the same loop in Rust is recognised as a
// `memset` or `memcpy` and compiled into a call to itself.

/// `memcpy(dest, src, n)`: `n` bytes from `src` to `dest` (not overlapping); returns `dest`.
///
/// # Safety
/// The C function's contract: `n` bytes readable at `src` and writable at `dest`.
#[no_mangle]
pub unsafe extern "C" fn memcpy(dest: *mut u8, src: *const u8, n: usize) -> *mut u8 {
    let [low, high] = n.to_le_bytes();
    // SAFETY: the caller's promise; the loop reads `n` bytes from Z = src and writes them
    // to X = dest, counting `n` down until it borrows (none when it is 0).
    unsafe {
        core::arch::asm!(
            "rjmp 2f",
            "1: ld {byte}, Z+",
            "st X+, {byte}",
            "2: subi {low}, 1",
            "sbci {high}, 0",
            "brcc 1b",
            byte = out(reg) _,
            low = inout(reg_upper) low => _,
            high = inout(reg_upper) high => _,
            inout("Z") src => _,
            inout("X") dest => _,
            options(nostack),
        );
    }
    dest
}

/// `memset(dest, value, n)`: the value's low byte stored in `n` bytes from `dest`; returns
/// `dest`.
///
/// # Safety
/// The C function's contract: `n` bytes writable at `dest`.
#[no_mangle]
pub unsafe extern "C" fn memset(dest: *mut u8, value: i16, n: usize) -> *mut u8 {
    let [low, high] = n.to_le_bytes();
    // SAFETY: the caller's promise; the loop stores the byte `n` times from Z = dest on,
    // counting `n` down until it borrows (none when it is 0).
    unsafe {
        core::arch::asm!(
            "rjmp 2f",
            "1: st Z+, {byte}",
            "2: subi {low}, 1",
            "sbci {high}, 0",
            "brcc 1b",
            byte = in(reg) value as u8,
            low = inout(reg_upper) low => _,
            high = inout(reg_upper) high => _,
            inout("Z") dest => _,
            options(nostack),
        );
    }
    dest
}

/// `memcmp(a, b, n)`: the first of `n` bytes that differ, `a`'s less `b`'s as unsigned bytes
/// (negative, zero or positive), or 0 when all are equal.
///
/// # Safety
/// The C function's contract: `n` bytes readable at `a` and at `b`.
#[no_mangle]
pub unsafe extern "C" fn memcmp(a: *const u8, b: *const u8, n: usize) -> i16 {
    let [low, high] = n.to_le_bytes();
    let (difference, sign): (u8, u8);
    // SAFETY: the caller's promise; the loop reads the bytes in turn from Z = a and X = b,
    // counting `n` down until it borrows, and stops at the first pair that differs: their
    // difference, with the borrow of that subtraction (a's byte below b's) as the sign.
    // When all are equal, both come out 0.
    unsafe {
        core::arch::asm!(
            "rjmp 2f",
            "1: ld {d}, Z+",
            "ld {s}, X+",
            "sub {d}, {s}",
            "brne 3f",
            "2: subi {low}, 1",
            "sbci {high}, 0",
            "brcc 1b",
            "sub {d}, {d}",
            "3: sbc {s}, {s}",
            d = out(reg) difference,
            s = out(reg) sign,
            low = inout(reg_upper) low => _,
            high = inout(reg_upper) high => _,
            inout("Z") a => _,
            inout("X") b => _,
            options(nostack, readonly),
        );
    }
    i16::from_le_bytes([difference, sign])
}
