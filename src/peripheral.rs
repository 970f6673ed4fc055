//! What the type of a PAC peripheral says about which one it is, read while the firmware
//! compiles (`core::any::type_name`, in a `const` block): a USART handed to `Slave::start`
//! other than the one `slave!` bound is then a build error, not an `Error` at run time.
//! `avr-device` 0.8 and 0.9 name a USART `Periph<usartN::RegisterBlock, ADDRESS>`, older
//! PACs `USARTn`; a name that tells neither is left to the run-time check of its address.

/// Whether the type named `type_name` may be USART `number`, whose register block is at
/// `address`: false only when its name says it is another.
pub(crate) const fn may_be_usart(type_name: &str, number: u8, address: usize) -> bool {
    let name = type_name.as_bytes();
    if let Some(named) = trailing_number(name) {
        return named == address;
    }
    match usart_suffix(name) {
        Some(named) => named == number,
        None => true,
    }
}

/// The decimal number a type name ends with as its last generic argument (`…, 200>`).
const fn trailing_number(name: &[u8]) -> Option<usize> {
    let Some((&b'>', rest)) = name.split_last() else { return None };
    let end = rest.len();
    let mut start = end;
    while start > 0 && rest[start - 1].is_ascii_digit() {
        start -= 1;
    }
    if start == end || start == 0 || !matches!(rest[start - 1], b' ' | b',') {
        return None;
    }
    let mut value = 0usize;
    let mut i = start;
    while i < end {
        value = value.saturating_mul(10).saturating_add((rest[i] - b'0') as usize);
        i += 1;
    }
    Some(value)
}

/// The `n` of a type name ending in `::USARTn`.
const fn usart_suffix(name: &[u8]) -> Option<u8> {
    let prefix = b"::USART";
    if name.len() < prefix.len() + 1 {
        return None;
    }
    let start = name.len() - prefix.len() - 1;
    let mut i = 0;
    while i < prefix.len() {
        if name[start + i] != prefix[i] {
            return None;
        }
        i += 1;
    }
    match name[name.len() - 1] {
        digit @ b'0'..=b'9' => Some(digit - b'0'),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::may_be_usart;

    #[test]
    fn avr_device_0_8_and_0_9_name_a_usart_by_its_address() {
        let usart1 =
            "avr_device::devices::atmega2560::Periph<avr_device::devices::atmega2560::usart1::RegisterBlock, 200>";
        assert!(may_be_usart(usart1, 1, 0xC8));
        assert!(!may_be_usart(usart1, 0, 0xC0));
        assert!(!may_be_usart(usart1, 2, 0xD0));
        let usart3 =
            "avr_device::devices::atmega2560::Periph<avr_device::devices::atmega2560::usart3::RegisterBlock, 304>";
        assert!(may_be_usart(usart3, 3, 0x130));
    }

    #[test]
    fn older_pacs_name_it_usart_n() {
        assert!(may_be_usart("avr_device::atmega328p::USART0", 0, 0xC0));
        assert!(!may_be_usart("avr_device::atmega2560::USART0", 1, 0xC8));
        assert!(!may_be_usart("avr_device::atmega2560::USART3", 1, 0xC8));
    }

    #[test]
    fn a_name_that_tells_nothing_is_left_to_the_run_time_check() {
        assert!(may_be_usart("my_hal::Serial", 1, 0xC8));
        assert!(may_be_usart("my_hal::Wrapper<my_hal::Usart>", 1, 0xC8));
        assert!(may_be_usart("USART1", 1, 0xC8));
        assert!(may_be_usart("a::Tuple<1, x>", 0, 0xC0));
        assert!(may_be_usart(">", 0, 0xC0));
        assert!(may_be_usart("", 0, 0xC0));
    }
}
