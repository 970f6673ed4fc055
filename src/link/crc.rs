//! CRC-16/MODBUS, Modbus over Serial Line v1.02 §2.5.1.2 and Appendix B.
//!
//! Polynomial 0x8005 reflected (0xA001), initial value 0xFFFF, no final xor; the CRC
//! travels low byte first. The byte step is loop-free and table-free: after the data byte
//! is folded into the low byte `l`, eight shift/xor rounds of 0xA001 equal
//! `(crc >> 8) ^ (l << 6) ^ (l << 7) ^ (0xC001 if l has odd parity)`, which costs a few
//! dozen AVR cycles and no flash for a table.
//!
//! Why: the rounds are linear. The high byte only shifts down into the low byte. A
//! round xors 0xA001 (bits 15, 13 and 0) when the bit it shifts out is 1, and that bit 0
//! feeds the next round's choice, so round `k` (0 to 7) xors when `d_k`, the parity of
//! `l`'s bits 0..=k, is 1. What is left of 0xA001 >> (7 − k) after the last round gives
//! `p` (= `d_7`, the parity of `l`) in bit 0 and `(D << 6) ^ (D << 8)` above, with
//! `D = Σ d_k·2^k`; since `D ^ (D << 1)` is `l` with `p` in bit 8, that is
//! `(l << 6) ^ (l << 7) ^ 0xC000·p` (`tests`: the step against eight rounds for every byte
//! and a spread of states).

/// An incremental CRC-16/MODBUS, fed one byte at a time as the UART delivers them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Crc16(u16);

impl Crc16 {
    /// A CRC over no bytes yet (0xFFFF).
    pub const fn new() -> Self {
        Crc16(0xFFFF)
    }

    /// Folds one more byte into the CRC.
    #[inline(always)]
    pub const fn update(self, byte: u8) -> Self {
        let l = (self.0 as u8) ^ byte;
        let mut next = (self.0 >> 8) ^ ((l as u16) << 6) ^ ((l as u16) << 7);
        // Parity of l by folding: bit 0 ends up as the xor of all eight bits.
        let mut parity = l ^ (l >> 4);
        parity ^= parity >> 2;
        parity ^= parity >> 1;
        if parity & 1 == 1 {
            next ^= 0xC001;
        }
        Crc16(next)
    }

    /// [`Crc16::update`] for the receive interrupt: on the AVR the step of
    /// [`Crc16::fold_avr`] in four registers (the data byte's is reused once folded in,
    /// the low byte's once `s` is formed), r24–r27, the ones the handler's other paths use
    /// already, so that it saves no more of them on every entry; the CRC travels in r27:r26
    /// as one `u16`, which loads and stores with no shuffling.
    #[inline(always)]
    #[cfg_attr(target_arch = "avr", allow(unsafe_code))]
    pub fn step(self, byte: u8) -> Self {
        #[cfg(target_arch = "avr")]
        {
            let mut crc = self.0;
            // r24: the data byte, then p; r25: s; r26: the low byte, l, then (s << 6) as u8;
            // r27: the high byte.
            // SAFETY: register arithmetic only: no memory, no stack.
            unsafe {
                core::arch::asm!(
                    "eor r26, r24", // l = low byte ^ data byte
                    "mov r24, r26",
                    "swap r24",
                    "eor r24, r26",
                    "mov r25, r24",
                    "lsr r25",
                    "lsr r25",
                    "eor r24, r25",
                    "mov r25, r24",
                    "lsr r25",
                    "eor r24, r25",
                    "andi r24, 1",
                    // s = l ^ (l << 1), bit 8 in carry; l is not needed after this.
                    "mov r25, r26",
                    "lsl r25",
                    "eor r25, r26",
                    "clr r26",
                    "ror r25",
                    "ror r26",
                    "ror r25",
                    "ror r26",
                    "eor r27, r26",
                    "eor r27, r24",
                    "neg r24",
                    "andi r24, 0xC0",
                    "eor r25, r24",
                    "mov r26, r27",
                    "mov r27, r25",
                    inout("r24") byte => _, // p once the byte is folded in
                    out("r25") _,           // s
                    inout("X") crc,         // r27:r26
                    options(pure, nomem, nostack),
                );
            }
            Crc16(crc)
        }
        #[cfg(not(target_arch = "avr"))]
        {
            self.update(byte)
        }
    }

    /// Folds a slice of bytes into the CRC, continuing from this state (the receiver checks
    /// a stored frame with it; bytes before the buffer can be folded in first). On the AVR
    /// a loop written out in assembly, 33 cycles a byte ([`Crc16::fold_avr`]); elsewhere
    /// [`Crc16::update`] byte after byte. One copy in flash, whoever calls it.
    #[inline(never)]
    pub fn update_slice(self, bytes: &[u8]) -> Self {
        #[cfg(target_arch = "avr")]
        {
            if bytes.is_empty() {
                self
            } else {
                self.fold_avr(bytes)
            }
        }
        #[cfg(not(target_arch = "avr"))]
        {
            bytes.iter().fold(self, |crc, &byte| crc.update(byte))
        }
    }

    /// [`Crc16::update`]'s step over the bytes (`bytes` is not empty): with `l` the
    /// low byte after the data byte is folded in, `s = l ^ (l << 1)` (9 bits) and `p` the
    /// parity of `l`, the new low byte is the old high byte ^ `(s << 6) as u8` ^ `p`, the
    /// new high byte `s >> 2` ^ (`p` · 0xC0). Branch-free: every byte takes the same time.
    #[cfg(target_arch = "avr")]
    #[allow(unsafe_code)]
    fn fold_avr(self, bytes: &[u8]) -> Self {
        let mut crc = self.0;
        // SAFETY: reads `bytes.len()` bytes from `bytes` (at least 1, and the count is
        // 16-bit like the length) and touches only the registers named; no stack, no memory written. The
        // registers are ones a call may change, so the caller saves none for it.
        unsafe {
            core::arch::asm!(
                "2:",
                "ld r18, Z+",
                "eor r24, r18", // l = low byte ^ data byte
                // p = parity of l: fold nibbles, then pairs, then bits into bit 0.
                "mov r19, r24",
                "swap r19",
                "eor r19, r24",
                "mov r20, r19",
                "lsr r20",
                "lsr r20",
                "eor r19, r20",
                "mov r20, r19",
                "lsr r20",
                "eor r19, r20",
                "andi r19, 1",
                // s = l ^ (l << 1), its bit 8 (= bit 7 of l) in carry (eor and clr keep it).
                "mov r20, r24",
                "lsl r20",
                "eor r20, r24",
                "clr r21",
                // s >> 2 in r20, (s << 6) as u8 in r21: bits 0 and 1 rotated across.
                "ror r20",
                "ror r21",
                "ror r20",
                "ror r21",
                // New low byte: old high ^ r21 ^ p; new high byte: s ^ (p ? 0xC0 : 0).
                "eor r25, r21",
                "eor r25, r19",
                "neg r19",
                "andi r19, 0xC0",
                "eor r20, r19",
                "mov r24, r25",
                "mov r25, r20",
                "sbiw r26, 1",
                "brne 2b",
                out("r18") _, // the data byte
                out("r19") _, // p
                out("r20") _, // s
                out("r21") _, // (s << 6) as u8
                inout("r25r24") crc, // the CRC, low byte in r24
                inout("X") bytes.len() => _, // bytes left
                inout("Z") bytes.as_ptr() => _,
                options(nostack, readonly),
            );
        }
        Crc16(crc)
    }

    /// A register at zero, for the tail of a message whose head comes later: the receiver
    /// folds the bytes past its buffer in from here while they arrive, and
    /// [`Crc16::join`] puts the head in front once it has been folded.
    pub const fn tail() -> Self {
        Crc16(0)
    }

    /// The CRC of the head this CRC was folded over followed by the `tail_len` bytes that
    /// `tail` (from [`Crc16::tail`]) was folded over. The byte step is linear in the
    /// register (xors and shifts only), so the head's register after `tail_len` zero bytes,
    /// xored with the tail's register, is what folding the tail after the head gives.
    pub fn join(self, tail: Crc16, tail_len: u16) -> Self {
        let mut head = self;
        for _ in 0..tail_len {
            head = head.step(0);
        }
        Crc16(head.0 ^ tail.0)
    }

    /// The CRC value.
    pub const fn value(self) -> u16 {
        self.0
    }

    /// The two bytes as they go on the wire: low byte first.
    pub const fn to_wire(self) -> [u8; 2] {
        self.0.to_le_bytes()
    }

    /// True once the frame's own CRC bytes have been folded in and they match: a CRC run
    /// over data followed by its correct CRC (low byte first) always ends at zero.
    pub const fn is_residue_ok(self) -> bool {
        self.0 == 0
    }
}

impl Default for Crc16 {
    fn default() -> Self {
        Self::new()
    }
}

/// The CRC-16/MODBUS of a whole slice.
pub fn crc16(bytes: &[u8]) -> u16 {
    Crc16::new().update_slice(bytes).value()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The CRC as the spec defines it: eight shift/xor rounds per byte.
    fn reference(bytes: &[u8]) -> u16 {
        let mut crc = 0xFFFFu16;
        for &b in bytes {
            crc ^= u16::from(b);
            for _ in 0..8 {
                crc = if crc & 1 == 1 { (crc >> 1) ^ 0xA001 } else { crc >> 1 };
            }
        }
        crc
    }

    #[test]
    fn spec_check_values_low_byte_first() {
        assert_eq!(Crc16::new().update_slice(&[0x11, 0x03, 0x00, 0x6B, 0x00, 0x03]).to_wire(), [0x76, 0x87]);
        assert_eq!(Crc16::new().update_slice(&[0x01, 0x04, 0x00, 0x00, 0x00, 0x01]).to_wire(), [0x31, 0xCA]);
        assert_eq!(Crc16::new().update_slice(&[0x11, 0x10, 0x00, 0x01, 0x00, 0x02]).to_wire(), [0x12, 0x98]);
    }

    #[test]
    fn byte_step_equals_bitwise_definition_for_every_state_and_byte() {
        for state in (0..=u16::MAX).step_by(97).chain([0, 0xFFFF, 0x8000, 0x0001]) {
            for byte in 0..=u8::MAX {
                let mut bitwise = state ^ u16::from(byte);
                for _ in 0..8 {
                    bitwise = if bitwise & 1 == 1 { (bitwise >> 1) ^ 0xA001 } else { bitwise >> 1 };
                }
                assert_eq!(Crc16(state).update(byte).value(), bitwise, "state {state:#06x} byte {byte:#04x}");
            }
        }
    }

    #[test]
    fn residue_is_zero_after_appending_the_crc() {
        let mut frame = [0x01, 0x03, 0x00, 0x00, 0x00, 0x0A, 0, 0];
        let crc = crc16(&frame[..6]).to_le_bytes();
        frame[6..].copy_from_slice(&crc);
        assert!(Crc16::new().update_slice(&frame).is_residue_ok());
        frame[7] ^= 1;
        assert!(!Crc16::new().update_slice(&frame).is_residue_ok());
    }

    #[test]
    fn a_head_joined_to_a_tail_folded_from_zero_is_the_crc_of_both() {
        let data: Vec<u8> = (0..300u16).map(|i| (i * 37 + 11) as u8).collect();
        for split in [0, 1, 7, 41, 200, 255, 299, 300] {
            let (head, tail) = data.split_at(split);
            let joined = Crc16::new().update_slice(head).join(Crc16::tail().update_slice(tail), tail.len() as u16);
            assert_eq!(joined.value(), reference(&data), "split at {split}");
        }
    }

    #[test]
    fn slice_crc_matches_reference_on_ramp() {
        let data: Vec<u8> = (0..=255).collect();
        assert_eq!(crc16(&data), reference(&data));
        assert_eq!(crc16(&[]), 0xFFFF);
    }
}
