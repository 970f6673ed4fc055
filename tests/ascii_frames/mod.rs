//! ASCII frames as the tests send and expect them, written from Serial Line v1.02 §2.5.2
//! (not with the crate's code).

/// The LRC of §2.5.2.2: the two's complement of the bytes' sum, kept to 8 bits.
pub fn lrc(bytes: &[u8]) -> u8 {
    let sum: u32 = bytes.iter().map(|&b| u32::from(b)).sum();
    ((256 - sum % 256) % 256) as u8
}

/// `bytes` (address and PDU) as an ASCII frame: `:`, upper-case hex pairs with the LRC,
/// CR LF.
pub fn ascii(bytes: &[u8]) -> Vec<u8> {
    let mut text = String::from(":");
    for b in bytes.iter().copied().chain([lrc(bytes)]) {
        text.push_str(&format!("{b:02X}"));
    }
    text.push_str("\r\n");
    text.into_bytes()
}
