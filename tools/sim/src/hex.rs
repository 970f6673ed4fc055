//! Intel HEX, the format bootloader images come in (`avr-objcopy -O ihex`): data records
//! (00), end of file (01), extended segment (02) and linear (04) addresses; start-address
//! records (03, 05) are ignored, as the chip starts where its fuses say.

/// One run of bytes at a flash byte address.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Chunk {
    /// Byte address of the first byte.
    pub addr: u32,
    /// The bytes.
    pub bytes: Vec<u8>,
}

/// Parses an Intel HEX text into chunks, consecutive records merged, in file order.
/// Errors name the line: a bad character, a short record or a wrong checksum.
pub fn parse(text: &str) -> Result<Vec<Chunk>, String> {
    let mut chunks: Vec<Chunk> = Vec::new();
    let mut base = 0u32;
    for (n, line) in text.lines().enumerate().map(|(i, l)| (i + 1, l.trim())) {
        if line.is_empty() {
            continue;
        }
        let hex = line.strip_prefix(':').ok_or_else(|| format!("line {n}: does not start with ':'"))?;
        let bytes = decode(hex).ok_or_else(|| format!("line {n}: not an even number of hex digits"))?;
        if bytes.len() < 5 || bytes.len() != 5 + usize::from(bytes[0]) {
            return Err(format!("line {n}: record length does not match its byte count"));
        }
        if bytes.iter().fold(0u8, |sum, b| sum.wrapping_add(*b)) != 0 {
            return Err(format!("line {n}: checksum does not match"));
        }
        let data = &bytes[4..bytes.len() - 1];
        let offset = u32::from(u16::from_be_bytes([bytes[1], bytes[2]]));
        match bytes[3] {
            0x00 => {
                let addr = base.wrapping_add(offset);
                match chunks.last_mut() {
                    Some(last) if last.addr + last.bytes.len() as u32 == addr => last.bytes.extend_from_slice(data),
                    _ => chunks.push(Chunk { addr, bytes: data.to_vec() }),
                }
            }
            0x01 => return Ok(chunks),
            0x02 if data.len() == 2 => base = u32::from(u16::from_be_bytes([data[0], data[1]])) << 4,
            0x04 if data.len() == 2 => base = u32::from(u16::from_be_bytes([data[0], data[1]])) << 16,
            0x03 | 0x05 => {}
            kind => return Err(format!("line {n}: record type {kind:02X} is not one of flash data")),
        }
    }
    Err("no end-of-file record".to_owned())
}

fn decode(hex: &str) -> Option<Vec<u8>> {
    if !hex.len().is_multiple_of(2) {
        return None;
    }
    (0..hex.len()).step_by(2).map(|i| u8::from_str_radix(hex.get(i..i + 2)?, 16).ok()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_merge_and_extended_addresses_apply() {
        // stk500v2's first lines (segment 0x3000 -> 0x30000 + 0xE000) and two adjacent records.
        let text = ":020000023000CC\n:10E000000D9489F10D94B2F10D94B2F10D94B2F129\n\
                    :10E010000D94B2F10D94B2F10D94B2F10D94B2F1F0\n:040000033000E000E9\n:00000001FF\n";
        let chunks = parse(text).unwrap();
        assert_eq!(chunks.len(), 1);
        assert_eq!(chunks[0].addr, 0x3E000);
        assert_eq!(chunks[0].bytes.len(), 32);
        assert_eq!(&chunks[0].bytes[..4], &[0x0D, 0x94, 0x89, 0xF1]);
        let linear = parse(":020000040001F9\n:0100100042AD\n:00000001FF\n").unwrap();
        assert_eq!(linear, vec![Chunk { addr: 0x10010, bytes: vec![0x42] }]);
    }

    #[test]
    fn damage_is_reported_with_its_line() {
        assert_eq!(parse(":0100100042AE\n:00000001FF\n").unwrap_err(), "line 1: checksum does not match");
        assert_eq!(parse(":020010004200\n").unwrap_err(), "line 1: record length does not match its byte count");
        assert_eq!(parse(":0100100042AD\n").unwrap_err(), "no end-of-file record");
        assert!(parse("0100100042AD\n").unwrap_err().contains("':'"));
    }
}
