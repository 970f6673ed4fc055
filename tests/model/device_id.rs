//! FC 43 (0x2B) / MEI type 14 (0x0E), Read Device Identification, Application Protocol
//! v1.1b3 §6.21, as the model knows it: a device's objects, the three streams and the
//! individual access, "more follows" and the next object id, the exceptions; and the
//! identifications the fixtures hand the bank under test (feature `device-id`).
//!
//! Written from the spec, not from the crate's encoder: the model keeps each object as its
//! id and value and builds every response from them.
//!
//! | spec | the model |
//! |------|-----------|
//! | categories | basic 0x00–0x02, regular 0x03–0x7F (0x07–0x7F reserved), extended 0x80–0xFF |
//! | code 01/02/03 | a stream of the objects the device has up to the category's last id; a device asked for more than its level answers at its own |
//! | start id | where the stream starts; an id the stream does not hold restarts it at 0x00 |
//! | code 04 | the one object asked for; exception 02 when the device lacks it |
//! | more follows | 0xFF with the next object's id when the next object does not fit the 253-byte PDU; else 0x00 and 0x00 |
//! | conformity | 0x81 (basic, stream and individual access), 0x82 with any regular object |
//! | exceptions | no identification or another MEI type 01; a PDU not 4 bytes or a code outside 01–04 03 (before 02) |

use std::collections::BTreeMap;
use std::sync::OnceLock;

use avr_modbus::Identification;

/// Largest PDU, Application Protocol §4.1.
const MAX_PDU: usize = 253;

/// A device's identification objects: id → value.
#[derive(Clone, Debug, PartialEq)]
pub struct Identity {
    objects: BTreeMap<u8, Vec<u8>>,
}

impl Identity {
    fn new(objects: &[(u8, &[u8])]) -> Self {
        Identity { objects: objects.iter().map(|&(id, value)| (id, value.to_vec())).collect() }
    }

    /// §6.21's conformity level for a device with stream and individual access: 0x81
    /// basic, 0x82 regular (any object 0x03–0x7F), 0x83 extended (any object from 0x80).
    pub fn conformity(&self) -> u8 {
        if self.objects.keys().any(|&id| id >= 0x80) {
            0x83
        } else if self.objects.keys().any(|&id| id >= 0x03) {
            0x82
        } else {
            0x81
        }
    }

    /// The objects in their wire form, each id, length, value, in id order: what the
    /// crate reads out of flash.
    fn wire(&self) -> Vec<u8> {
        let mut out = Vec::new();
        for (&id, value) in &self.objects {
            out.push(id);
            out.push(value.len() as u8);
            out.extend(value);
        }
        out
    }
}

/// The response PDU to the FC 43 request `pdu` from a device with `identity` (none: the
/// device offers no identification), or the exception code.
pub fn read_device_id(identity: Option<&Identity>, pdu: &[u8]) -> Result<Vec<u8>, u8> {
    // §6.19: MEI type 14 is the only one offered; without objects, none is.
    let Some(identity) = identity else { return Err(1) };
    if pdu.get(1) != Some(&0x0E) {
        return Err(1);
    }
    let &[function, mei, code, object] = pdu else { return Err(3) };
    // The last id of the category each code asks for; code 04 asks for one object.
    let last = match code {
        0x01 => 0x02,
        0x02 => 0x7F,
        0x03 => 0xFF,
        0x04 => object,
        _ => return Err(3),
    };
    let first = if code == 0x04 {
        if !identity.objects.contains_key(&object) {
            return Err(2);
        }
        object
    } else if object <= last && identity.objects.contains_key(&object) {
        object
    } else {
        0x00
    };
    // Function, MEI type, code, conformity, more follows, next object id, object count.
    let mut out = vec![function, mei, code, identity.conformity(), 0x00, 0x00, 0];
    for (&id, value) in identity.objects.range(first..=last) {
        if out.len() + 2 + value.len() > MAX_PDU {
            out[4] = 0xFF;
            out[5] = id;
            break;
        }
        out.push(id);
        out.push(value.len() as u8);
        out.extend(value);
        out[6] += 1;
    }
    Ok(out)
}

// ---- the identifications under test -----------------------------------------------------

/// `bytes` as the `&str` `identification!` takes.
const fn text(bytes: &'static [u8]) -> &'static str {
    match core::str::from_utf8(bytes) {
        Ok(text) => text,
        Err(_) => panic!("not UTF-8"),
    }
}

const SIXTY: &str = "abcdefghijklmnopqrstuvwxyzabcdefghijklmnopqrstuvwxyzabcdefgh";
const LONGEST: [&str; 7] = [
    text(&[b'0'; 244]),
    text(&[b'1'; 244]),
    text(&[b'2'; 244]),
    text(&[b'3'; 244]),
    text(&[b'4'; 244]),
    text(&[b'5'; 244]),
    text(&[b'6'; 244]),
];
const EIGHTY: [&str; 3] = [text(&[b'A'; 80]), text(&[b'B'; 80]), text(&[b'C'; 81])];

avr_modbus::identification! {
    /// The basic objects of §6.21's example.
    static SPEC = {
        vendor_name: "Company identification",
        product_code: "Product code XX",
        major_minor_revision: "V2.11",
    };
}

avr_modbus::identification! {
    /// Basic and regular objects, ProductName (04) left out.
    static REGULAR = {
        vendor_name: "Acme",
        product_code: "AC-16",
        major_minor_revision: "1.2",
        vendor_url: "https://acme.example",
        model_name: "Sixteen",
        user_application_name: "pump station",
    };
}

avr_modbus::identification! {
    /// Seven objects of 60 bytes: three to a response.
    static SIXTIES = {
        vendor_name: SIXTY,
        product_code: SIXTY,
        major_minor_revision: SIXTY,
        vendor_url: SIXTY,
        product_name: SIXTY,
        model_name: SIXTY,
        user_application_name: SIXTY,
    };
}

avr_modbus::identification! {
    /// Seven objects of 244 bytes, the longest: one to a response, which it fills.
    static LONGEST_EACH = {
        vendor_name: LONGEST[0],
        product_code: LONGEST[1],
        major_minor_revision: LONGEST[2],
        vendor_url: LONGEST[3],
        product_name: LONGEST[4],
        model_name: LONGEST[5],
        user_application_name: LONGEST[6],
    };
}

avr_modbus::identification! {
    /// The basic objects fill a response to its last byte (7 + 3 × 82 = 253); VendorUrl
    /// follows.
    static EXACT = {
        vendor_name: EIGHTY[0],
        product_code: EIGHTY[1],
        major_minor_revision: EIGHTY[0],
        vendor_url: "u",
    };
}

avr_modbus::identification! {
    /// One byte more than [`EXACT`]: MajorMinorRevision follows.
    static ONE_OVER = {
        vendor_name: EIGHTY[0],
        product_code: EIGHTY[1],
        major_minor_revision: EIGHTY[2],
        user_application_name: "app",
    };
}

avr_modbus::identification! {
    /// Short basic objects and the longest UserApplicationName, which follows them.
    static LAST_LONG = {
        vendor_name: "V",
        product_code: "P",
        major_minor_revision: "0",
        user_application_name: LONGEST[6],
    };
}

/// The declared identifications, the crate's and the model's of the same objects.
fn declared() -> Vec<(&'static Identification, Identity)> {
    let regular: [(u8, &[u8]); 6] = [
        (0x00, b"Acme"),
        (0x01, b"AC-16"),
        (0x02, b"1.2"),
        (0x03, b"https://acme.example"),
        (0x05, b"Sixteen"),
        (0x06, b"pump station"),
    ];
    let sixties: Vec<(u8, &[u8])> = (0..7).map(|id| (id, SIXTY.as_bytes())).collect();
    let longest: Vec<(u8, &[u8])> = (0..7).map(|id| (id, LONGEST[usize::from(id)].as_bytes())).collect();
    vec![
        (&SPEC, Identity::new(&[(0x00, b"Company identification"), (0x01, b"Product code XX"), (0x02, b"V2.11")])),
        (&REGULAR, Identity::new(&regular)),
        (&SIXTIES, Identity::new(&sixties)),
        (&LONGEST_EACH, Identity::new(&longest)),
        (
            &EXACT,
            Identity::new(&[
                (0x00, EIGHTY[0].as_bytes()),
                (0x01, EIGHTY[1].as_bytes()),
                (0x02, EIGHTY[0].as_bytes()),
                (0x03, b"u"),
            ]),
        ),
        (
            &ONE_OVER,
            Identity::new(&[
                (0x00, EIGHTY[0].as_bytes()),
                (0x01, EIGHTY[1].as_bytes()),
                (0x02, EIGHTY[2].as_bytes()),
                (0x06, b"app"),
            ]),
        ),
        (&LAST_LONG, Identity::new(&[(0x00, b"V"), (0x01, b"P"), (0x02, b"0"), (0x06, LONGEST[6].as_bytes())])),
    ]
}

/// Identifications drawn from a fixed seed: the three basic objects and each regular one
/// present or not, lengths near the edges of a response (1–244), any byte values. The
/// crate gets the model's wire form, in memory as the host keeps it.
fn drawn(count: usize) -> Vec<(&'static Identification, Identity)> {
    const LENGTHS: [usize; 16] = [1, 2, 3, 10, 58, 59, 60, 61, 80, 81, 119, 120, 121, 122, 243, 244];
    let mut seed = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed
    };
    (0..count)
        .map(|_| {
            let mut objects = BTreeMap::new();
            for id in 0..=6u8 {
                if id > 2 && next() % 3 == 0 {
                    continue;
                }
                let r = next();
                let len = if r % 4 == 0 { 1 + (r >> 8) as usize % 244 } else { LENGTHS[(r >> 8) as usize % 16] };
                objects.insert(id, (0..len).map(|_| next() as u8).collect());
            }
            let identity = Identity { objects };
            let wire: &'static [u8] = Box::leak(identity.wire().into_boxed_slice());
            let identification: &'static Identification =
                Box::leak(Box::new(Identification::in_flash(wire, identity.conformity())));
            (identification, identity)
        })
        .collect()
}

/// Every identification a fixture can give the bank: the declared ones first.
fn all() -> &'static [(&'static Identification, Identity)] {
    static ALL: OnceLock<Vec<(&'static Identification, Identity)>> = OnceLock::new();
    ALL.get_or_init(|| {
        let mut all = declared();
        all.extend(drawn(63 - all.len()));
        all
    })
}

/// The identification a fixture with `salt` gives the bank, chosen by the salt's high
/// byte: none for 0 (and every multiple of 64), then the declared ones (1–7), then the
/// drawn ones.
pub fn chosen(salt: u16) -> Option<(&'static Identification, &'static Identity)> {
    let all = all();
    let k = usize::from(salt >> 8) % (all.len() + 1);
    k.checked_sub(1).map(|k| (all[k].0, &all[k].1))
}
