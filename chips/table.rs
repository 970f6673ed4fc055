//! Reads `chips/chips.txt`, the description of every chip (its header says what each line
//! means), into one [`Facts`] per chip, in the file's order. Std only: the crate's build.rs
//! and tools/sim both include this file as a module of their own.

/// One USART of a chip.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Usart {
    /// Its number: 1 for USART1.
    pub number: u8,
    /// The data-space address of its register block (UCSRnA ... UDRn).
    pub block: u16,
    /// Its RX complete, data register empty and TX complete vector numbers (`__vector_N`).
    pub vectors: [u8; 3],
    /// Whether it is the one on the board's pins 0 and 1.
    pub pins_0_1: bool,
}

/// The timer whose input capture and output compare A make a serial line (AltSoftSerial's
/// pins).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Capture {
    /// Its number: 1 for Timer1.
    pub timer: u8,
    /// The data-space address of its block (TCCRnA ... OCRnBH).
    pub block: u16,
    /// TIMSKn's data-space address.
    pub timsk: u16,
    /// TIFRn's data-space address.
    pub tifr: u16,
    /// Its CAPT, COMPA and COMPB vector numbers (`__vector_N`).
    pub vectors: [u8; 3],
    /// The PINx address of the port with the ICP and OCnA pins.
    pub port: u16,
    /// The ICP pin's bit (RX) and the OCnA pin's bit (TX) on that port.
    pub pins: [u8; 2],
    /// The PAC's register block for the timer: its address and size in bytes.
    pub peripheral: (u16, u16),
}

/// One chip's facts.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Facts {
    /// avr-gcc's `-mmcu` name, rustc's `target-cpu`: `atmega328p`.
    pub cpu: String,
    /// Its part name as the data sheet writes it: `ATmega328P`.
    pub part: String,
    /// The chips that share its USARTs and vectors, as the build's errors name them.
    pub family: String,
    /// Its Arduino boards.
    pub boards: String,
    /// Its USARTs, by number.
    pub usarts: Vec<Usart>,
    /// Timer0's COMPA, COMPB and OVF vector numbers.
    pub timer0: [u8; 3],
    /// The EEPROM's size in bytes.
    pub eeprom: u16,
    /// The board's LED: its port's PINx data-space address, and its bit.
    pub led: (u16, u8),
    /// The SPI's SS, MOSI and SCK, and the board's pin 10: their bits on port B.
    pub spi: [u8; 4],
    /// Pin 2's external interrupt: vector, EICRx address, ISC shift, EIMSK bit, PINx
    /// address, port bit.
    pub pin2_int: (u8, u16, u8, u8, u16, u8),
    /// Bytes a CALL or an interrupt pushes.
    pub return_address_bytes: u8,
    /// Single-ended ADC channels.
    pub adc: u8,
    /// Whether Arduino pins 0-19 name its ports as on the Uno.
    pub uno_pins: bool,
    /// The timer of its capture line.
    pub capture: Capture,
}

impl Facts {
    /// The USART on the board's pins 0 and 1.
    pub fn pins_0_1(&self) -> &Usart {
        // parse() takes a chip only with exactly one.
        self.usarts.iter().find(|usart| usart.pins_0_1).expect("a pins-0/1 USART")
    }
}

/// Every chip `text` describes, or what is wrong with it (and on which line).
pub fn parse(text: &str) -> Result<Vec<Facts>, String> {
    let mut chips = Vec::new();
    let mut chip: Option<Partial> = None;
    for (index, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let (key, value) = line.split_once(char::is_whitespace).unwrap_or((line, ""));
        let value = value.trim();
        let at = |error: String| format!("chips.txt line {}: {error}", index + 1);
        if key == "chip" {
            if let Some(done) = chip.take() {
                chips.push(done.finish()?);
            }
            chip = Some(Partial { cpu: value.to_owned(), ..Partial::default() });
            continue;
        }
        let partial = chip.as_mut().ok_or_else(|| at(format!("`{key}` before the first `chip`")))?;
        partial.set(key, value).map_err(at)?;
    }
    match chip {
        Some(done) => chips.push(done.finish()?),
        None => return Err("chips.txt describes no chip".to_owned()),
    }
    Ok(chips)
}

/// A chip's block as read so far.
#[derive(Default)]
struct Partial {
    cpu: String,
    part: Option<String>,
    family: Option<String>,
    boards: Option<String>,
    usarts: Vec<Usart>,
    timer0: Option<[u8; 3]>,
    eeprom: Option<u16>,
    led: Option<(u16, u8)>,
    spi: Option<[u8; 4]>,
    pin2_int: Option<(u8, u16, u8, u8, u16, u8)>,
    return_address_bytes: Option<u8>,
    adc: Option<u8>,
    uno_pins: Option<bool>,
    capture: Option<Capture>,
}

impl Partial {
    /// Takes the line `key value`.
    fn set(&mut self, key: &str, value: &str) -> Result<(), String> {
        let words: Vec<&str> = value.split_whitespace().collect();
        match key {
            "part" => self.part = Some(value.to_owned()),
            "family" => self.family = Some(value.to_owned()),
            "boards" => self.boards = Some(value.to_owned()),
            "usart" => self.usarts.push(usart(&words)?),
            "timer0" => self.timer0 = Some(vectors(&words)?),
            "eeprom" => self.eeprom = Some(number(value)?),
            "led" => match words[..] {
                [pin, bit] => self.led = Some((number(pin)?, number(bit)?)),
                _ => return Err(format!("`led {value}`: a PINx address and a bit")),
            },
            "spi" => match words[..] {
                [ss, mosi, sck, cs] => self.spi = Some([number(ss)?, number(mosi)?, number(sck)?, number(cs)?]),
                _ => return Err(format!("`spi {value}`: the bits of SS, MOSI, SCK and pin 10 on port B")),
            },
            "pin2-int" => match words[..] {
                [vector, eicr, shift, bit, pin, pin_bit] => {
                    self.pin2_int = Some((
                        number(vector)?,
                        number(eicr)?,
                        number(shift)?,
                        number(bit)?,
                        number(pin)?,
                        number(pin_bit)?,
                    ))
                }
                _ => return Err(format!("`pin2-int {value}`: vector, EICRx, shift, EIMSK bit, PINx, bit")),
            },
            "return-address" => self.return_address_bytes = Some(number(value)?),
            "adc" => self.adc = Some(number(value)?),
            "uno-pins" => {
                self.uno_pins = Some(match value {
                    "yes" => true,
                    "no" => false,
                    _ => return Err(format!("`uno-pins {value}`: yes or no")),
                })
            }
            "capture" => self.capture = Some(capture(&words)?),
            _ => return Err(format!("unknown key `{key}`")),
        }
        Ok(())
    }

    /// The chip, if its block said everything.
    fn finish(self) -> Result<Facts, String> {
        let cpu = self.cpu;
        let missing = |key: &str| format!("chips.txt, chip `{cpu}`: no `{key}`");
        if !self.usarts.windows(2).all(|pair| pair[0].number < pair[1].number) {
            return Err(format!("chips.txt, chip `{cpu}`: its USARTs, each once, in order"));
        }
        if self.usarts.iter().filter(|usart| usart.pins_0_1).count() != 1 {
            return Err(format!("chips.txt, chip `{cpu}`: not exactly one USART marked pins-0/1"));
        }
        Ok(Facts {
            part: self.part.ok_or_else(|| missing("part"))?,
            family: self.family.ok_or_else(|| missing("family"))?,
            boards: self.boards.ok_or_else(|| missing("boards"))?,
            usarts: self.usarts,
            timer0: self.timer0.ok_or_else(|| missing("timer0"))?,
            eeprom: self.eeprom.ok_or_else(|| missing("eeprom"))?,
            led: self.led.ok_or_else(|| missing("led"))?,
            spi: self.spi.ok_or_else(|| missing("spi"))?,
            pin2_int: self.pin2_int.ok_or_else(|| missing("pin2-int"))?,
            return_address_bytes: self.return_address_bytes.ok_or_else(|| missing("return-address"))?,
            adc: self.adc.ok_or_else(|| missing("adc"))?,
            uno_pins: self.uno_pins.ok_or_else(|| missing("uno-pins"))?,
            capture: self.capture.ok_or_else(|| missing("capture"))?,
            cpu,
        })
    }
}

/// `TIMERn BLOCK TIMSK TIFR CAPT COMPA COMPB PINx RX TX PAC-ADDRESS PAC-SIZE`.
fn capture(words: &[&str]) -> Result<Capture, String> {
    let [timer, block, timsk, tifr, capt, compa, compb, port, rx, tx, address, size] = words[..] else {
        return Err(format!(
            "`capture {}`: TIMERn, block, TIMSK, TIFR, three vectors, PINx, RX and TX bits, the PAC's block and size",
            words.join(" ")
        ));
    };
    let timer = timer.strip_prefix("TIMER").ok_or_else(|| format!("`{timer}`: TIMERn"))?;
    Ok(Capture {
        timer: number(timer)?,
        block: number(block)?,
        timsk: number(timsk)?,
        tifr: number(tifr)?,
        vectors: [number(capt)?, number(compa)?, number(compb)?],
        port: number(port)?,
        pins: [number(rx)?, number(tx)?],
        peripheral: (number(address)?, number(size)?),
    })
}

/// `USARTn BLOCK RX UDRE TX [pins-0/1]`.
fn usart(words: &[&str]) -> Result<Usart, String> {
    let (name, block, vector_words, pins_0_1) = match *words {
        [name, block, ref vector_words @ ..] if vector_words.len() == 3 => (name, block, vector_words, false),
        [name, block, ref vector_words @ .., "pins-0/1"] if vector_words.len() == 3 => {
            (name, block, vector_words, true)
        }
        _ => return Err(format!("`usart {}`: USARTn, its block and three vectors", words.join(" "))),
    };
    let usart = name.strip_prefix("USART").and_then(|n| n.parse().ok()).filter(|&n: &u8| n < 4);
    let usart = usart.ok_or_else(|| format!("`{name}`: USART0 to USART3"))?;
    Ok(Usart { number: usart, block: number(block)?, vectors: vectors(vector_words)?, pins_0_1 })
}

/// Three vector numbers.
fn vectors(words: &[&str]) -> Result<[u8; 3], String> {
    match *words {
        [a, b, c] => Ok([number(a)?, number(b)?, number(c)?]),
        _ => Err(format!("`{}`: three vector numbers", words.join(" "))),
    }
}

/// A number, decimal or `0x` hexadecimal, that fits `T`.
fn number<T: TryFrom<u32>>(word: &str) -> Result<T, String> {
    let value = match word.strip_prefix("0x") {
        Some(hex) => u32::from_str_radix(hex, 16),
        None => word.parse(),
    };
    value.ok().and_then(|value| T::try_from(value).ok()).ok_or_else(|| format!("`{word}`: not a number that fits"))
}

#[cfg(test)]
mod tests {
    use super::*;

    const UNO: &str = "chip atmega328p\npart ATmega328P\nfamily ATmega328P\nboards Uno\n\
                       usart USART0 0xC0 18 19 20 pins-0/1   # the pins\ntimer0 14 15 16\neeprom 1024\n\
                       led 0x23 5\nspi 2 3 5 2\npin2-int 1 0x69 0 0 0x29 2\nreturn-address 2\nadc 8\nuno-pins yes\n\
                       capture TIMER1 0x80 0x6F 0x36 10 11 12 0x23 0 1 0x36 0x56\n";

    #[test]
    fn reads_a_block() {
        let chips = parse(UNO).unwrap();
        assert_eq!(chips.len(), 1);
        let uno = &chips[0];
        assert_eq!((uno.cpu.as_str(), uno.eeprom, uno.led, uno.timer0), ("atmega328p", 1024, (0x23, 5), [14, 15, 16]));
        assert_eq!(uno.pins_0_1(), &Usart { number: 0, block: 0xC0, vectors: [18, 19, 20], pins_0_1: true });
        assert_eq!(
            uno.capture,
            Capture {
                timer: 1,
                block: 0x80,
                timsk: 0x6F,
                tifr: 0x36,
                vectors: [10, 11, 12],
                port: 0x23,
                pins: [0, 1],
                peripheral: (0x36, 0x56)
            }
        );
    }

    #[test]
    fn a_missing_line_is_named() {
        let error = parse(&UNO.replace("eeprom 1024\n", "")).unwrap_err();
        assert!(error.contains("atmega328p") && error.contains("`eeprom`"), "{error}");
    }

    #[test]
    fn a_chip_needs_one_pins_0_1_usart() {
        let two = UNO.replace("timer0", "usart USART1 0xC8 25 26 27 pins-0/1\ntimer0");
        assert!(parse(&two).unwrap_err().contains("pins-0/1"));
        assert!(parse(&UNO.replace(" pins-0/1", "")).unwrap_err().contains("pins-0/1"));
    }

    #[test]
    fn bad_lines_are_refused() {
        assert!(parse(&UNO.replace("adc 8", "adc 300")).unwrap_err().contains("line 12"));
        assert!(parse(&UNO.replace("spi 2 3 5 2", "spi 2 3 5")).unwrap_err().contains("line 9"));
        assert!(parse(&UNO.replace("pin2-int 1 0x69 0 0 0x29 2", "pin2-int 1")).unwrap_err().contains("line 10"));
        assert!(parse(&UNO.replace("uno-pins yes", "uno-pins maybe")).is_err());
        assert!(parse(&UNO.replace("USART0", "USART4")).is_err());
        assert!(parse(&UNO.replace("18 19 20", "18 19")).is_err());
        assert!(parse(&UNO.replace("TIMER1 0x80", "TIMER1")).unwrap_err().contains("capture"));
        assert!(parse(&UNO.replace("capture TIMER1", "capture COUNTER1")).is_err());
        assert!(parse(&format!("{UNO}flash 32768\n")).unwrap_err().contains("unknown key"));
        assert!(parse("part ATmega328P\n").unwrap_err().contains("before the first `chip`"));
        assert!(parse("# nothing\n").unwrap_err().contains("no chip"));
    }
}
