//! A serial wire between a pty of its own and two pins of the simulated chip, for a UART the
//! firmware builds from a timer (feature `capture-line`: input capture on RX, output compare on
//! TX; the Uno's pins 8 and 9), in simulated time.
//!
//! Master to chip: each character's levels are scheduled on the RX pin at the master's line
//! settings, its start bit where the previous character's last stop bit ends, or at the cycle
//! the bytes reached us if that is later: back to back when the master writes a frame at once,
//! never in the past. Chip to master: TX's logged levels are read as the master's UART reads
//! them (`Uno::take_pin_uart`), and each character goes to the pty once its last stop bit has
//! ended; one with a bad parity or stop bit is reported and passed on, as a UART that does not
//! check parity passes it.
//!
//! The pty shows the master's baud rate, stop bits and odd parity, but neither its data bits
//! nor even parity (`line`): those two come from the frame given (`--pins-frame`, 8E: Modbus
//! RTU's even parity), unless the master set odd parity.

use std::fmt;
use std::path::Path;
use std::str::FromStr;

use uno_sim::{DecodedByte, Error, Parity as UnoParity, PinId, PinUart, Uno};

use crate::line::{Parity, Settings};
use crate::pace::cycles_to_duration;
use crate::pty::{Link, Pty};

/// A pin named on the command line: an Arduino Uno pin number (`8`) or a port and bit (`PL1`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PinName {
    /// An Uno pin number, 0-19, on the chips wired like the Uno.
    Uno(u8),
    /// Port letter and bit, on every chip.
    Port(char, u8),
}

impl PinId for PinName {
    fn port_bit(self, uno: &Uno) -> Result<(char, u8), Error> {
        match self {
            PinName::Uno(pin) => pin.port_bit(uno),
            PinName::Port(port, bit) => Ok((port, bit)),
        }
    }
}

/// What the pty cannot show of the master's frame: its data bits and whether "no parity" is
/// even parity.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HiddenFrame {
    /// Data bits, 7 or 8.
    pub data_bits: u8,
    /// The parity of a master whose termios shows none: none or even.
    pub parity: UnoParity,
}

impl HiddenFrame {
    /// 8 data bits, even parity: Modbus RTU's frame.
    pub const RTU: HiddenFrame = HiddenFrame { data_bits: 8, parity: UnoParity::Even };
}

impl FromStr for HiddenFrame {
    type Err = String;

    /// `8E`, `8N`, `7E` or `7N`.
    fn from_str(text: &str) -> Result<HiddenFrame, String> {
        let upper = text.to_ascii_uppercase();
        let data_bits = match &upper.get(..1) {
            Some("7") => 7,
            Some("8") => 8,
            _ => return Err(format!("--pins-frame: `{text}` is not 8E, 8N, 7E or 7N")),
        };
        let parity = match &upper[1..] {
            "E" => UnoParity::Even,
            "N" => UnoParity::None,
            _ => return Err(format!("--pins-frame: `{text}` is not 8E, 8N, 7E or 7N")),
        };
        Ok(HiddenFrame { data_bits, parity })
    }
}

/// What the master's settings put on the pins, told once per change.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PinsReport {
    /// The frame the master's characters get on RX, and the one its UART reads TX with.
    Frame { master: Settings, uart: PinUart },
    /// A rate or parity a pin's line does not carry: its bytes are dropped.
    Unsupported { master: Settings },
}

impl PinsReport {
    /// Whether this is a problem for stderr.
    pub fn is_trouble(&self) -> bool {
        matches!(self, PinsReport::Unsupported { .. })
    }
}

impl fmt::Display for PinsReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PinsReport::Frame { master, uart } => {
                write!(f, "the master's {master} is {} on the pins", frame_name(uart))
            }
            PinsReport::Unsupported { master } => write!(
                f,
                "the master's {master} cannot be carried on the pins (a standard rate with no, even or odd \
                 parity): its bytes are dropped"
            ),
        }
    }
}

/// `19200 8E1`.
fn frame_name(uart: &PinUart) -> String {
    let parity = match uart.parity {
        UnoParity::None => 'N',
        UnoParity::Even => 'E',
        UnoParity::Odd => 'O',
    };
    format!("{} {}{parity}{}", uart.baud, uart.data_bits, uart.stop_bits)
}

/// Both directions of the wire on two pins, and the pty they serve.
pub struct PinWire {
    rx: (char, u8),
    tx: (char, u8),
    hidden: HiddenFrame,
    pty: Pty,
    _link: Option<Link>,
    /// End cycle of the last character scheduled on RX.
    last_rx_end: u64,
    /// The master's settings last reported.
    reported: Option<Settings>,
    rx_count: u64,
    tx_count: u64,
    malformed: u64,
}

impl PinWire {
    /// The wire on `rx` (driven from outside, idle high from now) and `tx` (its levels logged
    /// from now), on a new pty linked from `link` if given.
    pub fn open(
        uno: &mut Uno,
        (rx, tx): (PinName, PinName),
        hidden: HiddenFrame,
        link: Option<&Path>,
    ) -> Result<PinWire, String> {
        let port_bit = |pin: PinName| pin.port_bit(uno).map_err(|e| format!("--pins: {e}"));
        let (rx, tx) = (port_bit(rx)?, port_bit(tx)?);
        uno.drive_port_pin(rx.0, rx.1, Some(true)).map_err(|e| format!("--pins: RX: {e}"))?;
        uno.watch_pin(tx).map_err(|e| format!("--pins: TX: {e}"))?;
        let pty = Pty::open().map_err(|e| format!("cannot open a pseudo-terminal: {e}"))?;
        let link = match link {
            Some(path) => {
                Some(Link::create(path, pty.path()).map_err(|e| format!("cannot link {}: {e}", path.display()))?)
            }
            None => None,
        };
        Ok(PinWire {
            rx,
            tx,
            hidden,
            pty,
            _link: link,
            last_rx_end: 0,
            reported: None,
            rx_count: 0,
            tx_count: 0,
            malformed: 0,
        })
    }

    /// The pty, for `poll` and to print.
    pub fn pty(&self) -> &Pty {
        &self.pty
    }

    /// `RX PB0, TX PB1`.
    pub fn pins(&self) -> String {
        format!("RX P{}{}, TX P{}{}", self.rx.0, self.rx.1, self.tx.0, self.tx.1)
    }

    /// The master's line settings, as its termios shows them.
    fn master(&self) -> Result<Settings, String> {
        self.pty.master_settings().map_err(|e| format!("reading the pins' pty settings: {e}"))
    }

    /// Schedules on RX what the master has written to the pty. Returns what its line settings
    /// mean on the pins, when that changed.
    pub fn receive(&mut self, uno: &mut Uno) -> Result<Option<PinsReport>, String> {
        let mut buf = [0u8; 1024];
        let n = self.pty.read(&mut buf).map_err(|e| format!("reading the pins' pty: {e}"))?;
        if n == 0 {
            return Ok(None);
        }
        let master = self.master()?;
        let uart = pin_uart(master, self.hidden);
        let report = (self.reported != Some(master)).then_some(match uart {
            Some(uart) => PinsReport::Frame { master, uart },
            None => PinsReport::Unsupported { master },
        });
        self.reported = Some(master);
        if let Some(uart) = uart {
            let start = self.last_rx_end.max(uno.now());
            self.last_rx_end = uno.send_pin_uart(self.rx, &buf[..n], uart, start, 0).map_err(|e| e.to_string())?;
            self.rx_count += n as u64;
        }
        Ok(report)
    }

    /// Writes to the pty every character TX has finished; returns a line for each malformed
    /// one. Characters nobody reads are dropped once the pty's buffer is full, as on a wire.
    pub fn transmit(&mut self, uno: &mut Uno) -> Result<Vec<String>, String> {
        let Some(uart) = pin_uart(self.master()?, self.hidden) else {
            uno.take_pin_edges(self.tx).map_err(|e| e.to_string())?;
            return Ok(Vec::new());
        };
        let chars = uno.take_pin_uart(self.tx, uart).map_err(|e| e.to_string())?;
        let bytes: Vec<u8> = chars.iter().map(|c| c.byte).collect();
        self.pty.write(&bytes).map_err(|e| format!("writing the pins' pty: {e}"))?;
        self.tx_count += bytes.len() as u64;
        let troubles: Vec<String> = chars.iter().filter_map(|c| malformed(c, &uart)).collect();
        self.malformed += troubles.len() as u64;
        Ok(troubles)
    }

    /// Bytes received from the master, sent to it, and of those how many malformed.
    pub fn counts(&self) -> (u64, u64, u64) {
        (self.rx_count, self.tx_count, self.malformed)
    }
}

/// The frame the master's settings mean on a pin, `hidden` filling in what the pty hides; `None`
/// if a pin's line does not carry it (mark or space parity, a rate the termios does not name).
fn pin_uart(master: Settings, hidden: HiddenFrame) -> Option<PinUart> {
    let parity = match master.parity {
        Parity::NoneOrEven => hidden.parity,
        Parity::None => UnoParity::None,
        Parity::Even => UnoParity::Even,
        Parity::Odd => UnoParity::Odd,
        Parity::Mark | Parity::Space => return None,
    };
    let uart = PinUart::new(master.baud).data_bits(hidden.data_bits).parity(parity).stop_bits(master.stop_bits);
    (master.baud > 0).then_some(uart)
}

/// `pin line: TX sent 0x12 at 1.234567 s (cycle N), read at 19200 8E1 with a bad parity bit`,
/// if it is bad. The master's settings may be what is wrong (a pty nobody has set is at 38400).
fn malformed(c: &DecodedByte, uart: &PinUart) -> Option<String> {
    let what = match (c.parity_ok, c.stop_ok) {
        (true, true) => return None,
        (false, true) => "a bad parity bit",
        (true, false) => "its stop bit low",
        (false, false) => "a bad parity bit and its stop bit low",
    };
    let (byte, cycle, at) = (c.byte, c.start_cycle, cycles_to_duration(c.start_cycle).as_secs_f64());
    let frame = frame_name(uart);
    Some(format!("pin line: TX sent 0x{byte:02x} at {at:.6} s (cycle {cycle}), read at {frame} with {what}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hidden_frames_parse() {
        assert_eq!("8E".parse(), Ok(HiddenFrame::RTU));
        assert_eq!("7n".parse(), Ok(HiddenFrame { data_bits: 7, parity: UnoParity::None }));
        assert!("8O".parse::<HiddenFrame>().unwrap_err().contains("8O"));
        assert!("9E".parse::<HiddenFrame>().is_err());
        assert!("".parse::<HiddenFrame>().is_err());
    }

    fn settings(baud: u32, parity: Parity, stop_bits: u8) -> Settings {
        Settings { baud, data_bits: 8, parity, stop_bits }
    }

    #[test]
    fn a_pty_showing_no_parity_gets_the_hidden_frame() {
        let rtu = PinUart::new(19200).parity(UnoParity::Even);
        assert_eq!(pin_uart(settings(19200, Parity::NoneOrEven, 1), HiddenFrame::RTU), Some(rtu));
        let ascii = HiddenFrame { data_bits: 7, parity: UnoParity::Even };
        let seven_e_one = PinUart::new(9600).data_bits(7).parity(UnoParity::Even);
        assert_eq!(pin_uart(settings(9600, Parity::NoneOrEven, 1), ascii), Some(seven_e_one));
        let none = HiddenFrame { data_bits: 8, parity: UnoParity::None };
        assert_eq!(pin_uart(settings(19200, Parity::NoneOrEven, 2), none), Some(PinUart::new(19200).stop_bits(2)));
    }

    #[test]
    fn what_the_pty_shows_is_the_masters() {
        let odd = pin_uart(settings(38400, Parity::Odd, 2), HiddenFrame::RTU);
        assert_eq!(odd, Some(PinUart::new(38400).parity(UnoParity::Odd).stop_bits(2)));
        assert_eq!(pin_uart(settings(19200, Parity::Mark, 1), HiddenFrame::RTU), None);
        assert_eq!(pin_uart(settings(19200, Parity::Space, 1), HiddenFrame::RTU), None);
        assert_eq!(pin_uart(settings(0, Parity::NoneOrEven, 1), HiddenFrame::RTU), None);
    }

    #[test]
    fn a_malformed_character_is_told_with_the_frame_it_was_read_at() {
        let uart = PinUart::new(19200).parity(UnoParity::Even);
        let good = DecodedByte { byte: 0x31, start_cycle: 16_000, end_cycle: 25_167, parity_ok: true, stop_ok: true };
        assert_eq!(malformed(&good, &uart), None);
        let bad = DecodedByte { parity_ok: false, ..good };
        let told = "pin line: TX sent 0x31 at 0.001000 s (cycle 16000), read at 19200 8E1 with a bad parity bit";
        assert_eq!(malformed(&bad, &uart).as_deref(), Some(told));
        let no_stop = DecodedByte { stop_ok: false, ..good };
        assert!(malformed(&no_stop, &PinUart::new(38400))
            .unwrap()
            .ends_with("read at 38400 8N1 with its stop bit low"));
    }
}
