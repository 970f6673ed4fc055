//! FC 43 (0x2B) with MEI type 14 (0x0E), Read Device Identification, Modbus Application
//! Protocol v1.1b3 §6.21 (feature `device-id`).
//!
//! The objects are fixed when the firmware is built ([`crate::identification!`]) and kept
//! in flash in their wire form (id, length, value, in id order), so a reply is a copy.
//!
//! | code | access | objects sent |
//! |------|--------|--------------|
//! | 01 | stream | basic: 00 VendorName, 01 ProductCode, 02 MajorMinorRevision |
//! | 02 | stream | basic, then regular: 03 VendorUrl, 04 ProductName, 05 ModelName, 06 UserApplicationName |
//! | 03 | stream | as 02: there are no extended objects, and §6.21 has a device answer a higher level at its own |
//! | 04 | one object | the one asked for; exception 02 when the device lacks it |
//!
//! A stream that starts at an object the device lacks starts over at 00. Objects that do
//! not all fit one reply: "more follows" FF and the id of the first one left out, where the
//! master asks again. The conformity level is 81 (basic, streams and single objects) or 82
//! when a regular object is there.
//!
//! Checks, in order: another MEI type, or no identification given → 01; a PDU that is not
//! 4 bytes, or a code outside 01–04 → 03; code 04 for an object the device lacks → 02.

use super::Exception;

/// MEI type 14 (0x0E): Read Device Identification.
pub const READ_DEVICE_ID: u8 = 0x0E;

/// The longest object value: a single object always fits one reply, header and all.
pub const MAX_OBJECT: usize = MAX_PDU - HEADER - 2;

/// Function code, MEI type, code, conformity, more follows, next object id, object count.
const HEADER: usize = 7;

/// The longest PDU, Application Protocol §4.1.
const MAX_PDU: usize = 253;

/// The last basic object's id (MajorMinorRevision).
const LAST_BASIC: u8 = 0x02;

/// The last regular object's id (UserApplicationName).
const LAST_REGULAR: u8 = 0x06;

/// The objects [`crate::identification!`] takes, by name; the three basic ones are
/// mandatory, an empty regular one is left out.
#[derive(Clone, Copy, Debug)]
pub struct Objects {
    /// 0x00 VendorName (mandatory).
    pub vendor_name: &'static str,
    /// 0x01 ProductCode (mandatory).
    pub product_code: &'static str,
    /// 0x02 MajorMinorRevision (mandatory).
    pub major_minor_revision: &'static str,
    /// 0x03 VendorUrl.
    pub vendor_url: &'static str,
    /// 0x04 ProductName.
    pub product_name: &'static str,
    /// 0x05 ModelName.
    pub model_name: &'static str,
    /// 0x06 UserApplicationName.
    pub user_application_name: &'static str,
}

impl Objects {
    /// No object given: what [`crate::identification!`] fills the others with.
    pub const NONE: Objects = Objects {
        vendor_name: "",
        product_code: "",
        major_minor_revision: "",
        vendor_url: "",
        product_name: "",
        model_name: "",
        user_application_name: "",
    };

    const fn by_id(&self) -> [&'static str; 7] {
        [
            self.vendor_name,
            self.product_code,
            self.major_minor_revision,
            self.vendor_url,
            self.product_name,
            self.model_name,
            self.user_application_name,
        ]
    }

    /// The length of their wire form. Fails the build for a missing basic object or one
    /// longer than [`MAX_OBJECT`].
    pub const fn encoded_len(&self) -> usize {
        let all = self.by_id();
        let mut len = 0;
        let mut id = 0;
        while id < all.len() {
            let value = all[id].len();
            assert!(value <= MAX_OBJECT, "an identification object is longer than 244 bytes");
            assert!(
                value > 0 || id > LAST_BASIC as usize,
                "vendor_name, product_code and major_minor_revision are mandatory"
            );
            if value > 0 {
                len += 2 + value;
            }
            id += 1;
        }
        len
    }

    /// Their wire form: id, length and value of each object given, in id order.
    pub const fn encode<const N: usize>(&self) -> [u8; N] {
        let all = self.by_id();
        let mut out = [0; N];
        let mut at = 0;
        let mut id = 0;
        while id < all.len() {
            let value = all[id].as_bytes();
            if !value.is_empty() {
                out[at] = id as u8;
                out[at + 1] = value.len() as u8;
                let mut k = 0;
                while k < value.len() {
                    out[at + 2 + k] = value[k];
                    k += 1;
                }
                at += 2 + value.len();
            }
            id += 1;
        }
        assert!(at == N, "the array is not encoded_len() long");
        out
    }

    /// The conformity level: 0x82 when a regular object is given, else 0x81.
    pub const fn conformity(&self) -> u8 {
        let regular = !self.vendor_url.is_empty()
            || !self.product_name.is_empty()
            || !self.model_name.is_empty()
            || !self.user_application_name.is_empty();
        if regular {
            0x82
        } else {
            0x81
        }
    }
}

/// A device's identification objects, in flash on AVR: declare it with
/// [`crate::identification!`] and hand it to the register map (`set_identification`).
pub struct Identification {
    /// On AVR an address in program memory, read with `lpm` only.
    objects: &'static [u8],
    conformity: u8,
}

impl Identification {
    /// The objects `encoded` ([`Objects::encode`]) at conformity level `conformity`. On
    /// AVR, `encoded` must be in program memory (section `.progmem.data`), where
    /// [`crate::identification!`] puts it: it is read with `lpm`.
    #[doc(hidden)]
    pub const fn in_flash(encoded: &'static [u8], conformity: u8) -> Self {
        Identification { objects: encoded, conformity }
    }

    /// Byte `at` of the encoded objects (0 past the end).
    fn byte(&self, at: usize) -> u8 {
        #[cfg(target_arch = "avr")]
        {
            if at >= self.objects.len() {
                return 0;
            }
            let out: u8;
            #[allow(unsafe_code)]
            // SAFETY: `lpm` reads a byte of program memory, where the objects are, and
            // `at` is inside them; it touches nothing else.
            unsafe {
                core::arch::asm!(
                    "lpm {out}, Z",
                    out = out(reg) out,
                    in("Z") self.objects.as_ptr().wrapping_add(at),
                    options(pure, readonly, nostack, preserves_flags),
                );
            }
            out
        }
        #[cfg(not(target_arch = "avr"))]
        self.objects.get(at).copied().unwrap_or(0)
    }

    /// The objects as `(id, offset of its length byte)`, in id order.
    fn objects(&self) -> impl Iterator<Item = (u8, usize)> + '_ {
        let mut at = 0;
        core::iter::from_fn(move || {
            if at + 1 >= self.objects.len() {
                return None;
            }
            let object = (self.byte(at), at + 1);
            at += 2 + usize::from(self.byte(at + 1));
            Some(object)
        })
    }

    fn has(&self, id: u8) -> bool {
        self.objects().any(|(object, _)| object == id)
    }
}

/// The objects by id, each value as the text it is (read from flash on AVR).
impl core::fmt::Debug for Identification {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let mut map = f.debug_map();
        for (id, at) in self.objects() {
            map.key(&id).value(&Value { identification: self, at });
        }
        map.finish()
    }
}

/// The value of the object whose length byte is at `at`.
struct Value<'a> {
    identification: &'a Identification,
    at: usize,
}

impl core::fmt::Debug for Value<'_> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        use core::fmt::Write;
        f.write_char('"')?;
        for k in 0..usize::from(self.identification.byte(self.at)) {
            f.write_char(char::from(self.identification.byte(self.at + 1 + k)))?;
        }
        f.write_char('"')
    }
}

/// Handles FC 43 in `pdu[..len]` and writes the response PDU over it, like
/// [`super::respond`]; `identification` is the data model's (none: exception 01). The
/// objects sent are cut where the buffer (less 2 bytes for the CRC) or the 253-byte PDU
/// ends. For a broadcast (`reply` false) the request is only checked.
pub fn respond(
    pdu: &mut [u8],
    len: usize,
    identification: Option<&Identification>,
    reply: bool,
) -> Result<usize, Exception> {
    let request = pdu.get(..len).ok_or(Exception::ServerDeviceFailure)?;
    let Some(identification) = identification.filter(|_| request.get(1) == Some(&READ_DEVICE_ID)) else {
        return Err(Exception::IllegalFunction);
    };
    let [function, mei, code @ 0x01..=0x04, object] = *request else {
        return Err(Exception::IllegalDataValue);
    };
    let single = code == 0x04;
    if single && !identification.has(object) {
        return Err(Exception::IllegalDataAddress);
    }
    if !reply {
        return Ok(0);
    }
    let last = if single {
        object
    } else if code == 0x01 {
        LAST_BASIC
    } else {
        LAST_REGULAR
    };
    let first = if object <= last && identification.has(object) { object } else { 0 };
    let room = pdu.len().saturating_sub(2).min(MAX_PDU);
    let (mut end, mut count, mut more, mut next) = (HEADER, 0u8, 0x00, 0x00);
    for (id, at) in identification.objects().filter(|&(id, _)| (first..=last).contains(&id)) {
        let size = 2 + usize::from(identification.byte(at));
        let Some(slot) = pdu.get_mut(end..end + size).filter(|_| end + size <= room) else {
            (more, next) = (0xFF, id);
            break;
        };
        for (k, byte) in slot.iter_mut().enumerate() {
            *byte = identification.byte(at - 1 + k);
        }
        end += size;
        count += 1;
    }
    let header = [function, mei, code, identification.conformity, more, next, count];
    pdu.get_mut(..HEADER).ok_or(Exception::ServerDeviceFailure)?.copy_from_slice(&header);
    Ok(end)
}

/// Declares a device's identification for FC 43 / MEI 14 (feature `device-id`): the
/// objects are encoded while the firmware compiles and kept in flash, and a missing basic
/// object, or one over 244 bytes, fails the build. Hand it to the map with
/// `set_identification(&IDENTITY)`.
///
/// ```
/// avr_modbus::identification! {
///     /// What FC 43 tells a master.
///     pub static IDENTITY = {
///         vendor_name: "Acme Controls",
///         product_code: "AC-16",
///         major_minor_revision: "1.2",
///         product_name: "Pump station I/O", // regular objects are optional
///     };
/// }
/// ```
///
/// The three basic objects are mandatory:
///
/// ```compile_fail
/// avr_modbus::identification! {
///     static IDENTITY = { vendor_name: "Acme Controls", product_code: "AC-16" };
/// }
/// let _ = &IDENTITY;
/// ```
#[macro_export]
macro_rules! identification {
    ($(#[$attr:meta])* $vis:vis static $name:ident = { $($field:ident: $value:expr),* $(,)? };) => {
        $(#[$attr])*
        $vis static $name: $crate::Identification = {
            #[allow(clippy::needless_update)] // when every object is given
            const OBJECTS: $crate::internal::device_id::Objects =
                $crate::internal::device_id::Objects { $($field: $value,)* ..$crate::internal::device_id::Objects::NONE };
            #[cfg_attr(target_arch = "avr", link_section = ".progmem.data")]
            static ENCODED: [u8; OBJECTS.encoded_len()] = OBJECTS.encode();
            $crate::Identification::in_flash(&ENCODED, OBJECTS.conformity())
        };
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The basic objects, the vendor name `vendor_len` bytes long.
    fn objects(vendor_len: usize) -> Objects {
        Objects {
            vendor_name: "a".repeat(vendor_len).leak(),
            product_code: "P",
            major_minor_revision: "1",
            ..Objects::NONE
        }
    }

    #[test]
    fn an_object_of_244_bytes_fits_a_reply() {
        assert_eq!(MAX_OBJECT, 244);
        assert_eq!(objects(244).encoded_len(), (2 + 244) + (2 + 1) + (2 + 1));
    }

    #[test]
    #[should_panic(expected = "longer than 244 bytes")]
    fn an_object_of_245_bytes_is_refused() {
        objects(245).encoded_len();
    }
}
