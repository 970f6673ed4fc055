//! USART RX complete, for either role: the character, or the damage it came with, to the
//! role's protocol state ([`Receive`]). In ASCII framing (feature `ascii`) the character
//! whose arrival makes a frame's outcome due (its LF, or a `:` that drops the frame in
//! progress) has Timer0 report the frame's end once it has left the line.

use super::timer::{FrameTimer, Unit};
use super::usart::Usart;
use crate::link::framing::Framing;
use crate::link::Receive;

/// The received character to `engine`. The interrupt handler set the silence deadlines
/// before it got here (`timer::on_receive`), so that they count from as close to the
/// USART's receive flag as can be.
#[inline(always)]
pub(crate) fn receive<const U: u8, T: Unit>(usart: &Usart<U>, timer: &mut FrameTimer<T>, engine: &mut impl Receive) {
    match engine.framing() {
        Framing::Rtu => {
            let _ = &timer;
            match usart.read() {
                Ok(byte) => engine.on_byte(byte),
                Err(e) => engine.on_error(e),
            }
        }
        #[cfg(feature = "ascii")]
        Framing::Ascii => match usart.read() {
            Ok(c) => {
                if engine.on_char(c) {
                    timer.end_now();
                }
            }
            Err(e) => engine.on_error(e),
        },
    }
}
