//! The slave's interrupt state: its peripherals, protocol engine, data model and pins,
//! and what each of its interrupts does with them (Modbus over Serial Line v1.02 §2.5.1.1:
//! every character sets the silence deadlines on Timer0 anew, T3.5 of silence ends the
//! frame, and the reply starts from that same interrupt). Reached only with interrupts
//! disabled, through [`super::Slave`].

use embedded_hal::digital::OutputPin;

use crate::avr::receive::receive;
use crate::avr::started::open_line;
use crate::avr::timer::{Compare, FrameTimer, Passed};
use crate::avr::usart::Usart;
use crate::link::config::Config;
use crate::link::framing::Framing;
use crate::slave::engine::{EndOfFrame, Engine};
use crate::slave::model::DataModel;

#[cfg(feature = "ascii")]
mod ascii;

/// The running slave: its peripherals, protocol state with a frame buffer of `N` bytes,
/// the application's data model `M`, the RS-485 driver-enable pin `DE` and the
/// communication LED `LED`, on USART `U` and Timer0's compare unit `C`. It lives in a
/// [`Slave`] and is reached only with interrupts disabled.
#[repr(C)]
pub(crate) struct Running<M, DE, LED, const N: usize, const U: u8, const C: char> {
    // First, in declaration order (`repr(C)`): the engine starts with the fields that start
    // other than zero, the rest of the slave follows its run of zeros (see `Engine`).
    pub(super) engine: Engine<N>,
    pub(super) usart: Usart<U>,
    pub(super) timer: FrameTimer<Compare<C>>,
    pub(super) model: M,
    /// Index of the reply's next byte, and the reply's length (at most 255 bytes; in
    /// ASCII framing, characters: at most 513).
    pub(super) tx_next: TxIndex,
    pub(super) tx_len: TxIndex,
    pub(super) driver_enable: DE,
    pub(super) led: LED,
    /// The reply delay after T3.5, in Timer0 ticks (feature `reply-delay`; 0: none).
    #[cfg(feature = "reply-delay")]
    pub(super) reply_delay: u16,
}

/// A position in the reply as it goes out: bytes, or with feature `ascii` characters.
#[cfg(not(feature = "ascii"))]
type TxIndex = u8;
#[cfg(feature = "ascii")]
type TxIndex = u16;

impl<M: DataModel, DE: OutputPin, LED: OutputPin, const N: usize, const U: u8, const C: char>
    Running<M, DE, LED, N, U, C>
{
    /// Configures the USART and Timer0 for `config` and starts the power-up wait (T3.5 of
    /// silence before the first frame; none in ASCII framing).
    pub(super) fn new(config: Config, model: M, mut driver_enable: DE, mut led: LED) -> Self {
        const { assert!(N >= M::FRAME, "the slave's frame buffer is smaller than its data model needs") };
        #[allow(unused_mut)]
        let (usart, mut timer) = open_line(config.line(), &mut driver_enable, &mut led);
        #[allow(unused_mut)]
        let mut engine = Engine::new(config.slave_id());
        #[cfg(feature = "ascii")]
        set_mode(&mut engine, &mut timer, config.line());
        Running {
            usart,
            timer,
            engine,
            model,
            tx_next: 0,
            tx_len: 0,
            driver_enable,
            led,
            #[cfg(feature = "reply-delay")]
            reply_delay: config.reply_delay_ticks(),
        }
    }

    /// USART RX complete: one character (or a damaged one) arrived. The interrupt handler
    /// set the silence deadlines before it got here (`timer::on_receive`), so that they
    /// count from as close to the USART's receive flag as can be.
    #[inline(always)]
    pub(super) fn on_usart_rx(&mut self) {
        receive(&self.usart, &mut self.timer, &mut self.engine);
    }

    /// Timer0's compare unit `C`: a frame's end, when it is one (the RTU silences here, ASCII's in
    /// `ascii.rs`). A frame for this slave is answered from here: the first character (the
    /// address, in ASCII `:`) goes out first, then the request is processed and the reply's
    /// CRC (LRC) appended while it is on the wire.
    #[inline(always)]
    pub(super) fn on_timer_compare(&mut self) {
        let passed = self.timer.on_compare();
        // The gap deadline: RTU's T1.5, ASCII's inter-character timeout.
        if passed == Passed::Gap {
            self.engine.on_gap_deadline();
        }
        let ended = match self.engine.framing() {
            Framing::Rtu => self.rtu_ended(passed),
            #[cfg(feature = "ascii")]
            Framing::Ascii => self.ascii_ended(passed),
        };
        if !ended {
            return;
        }
        let end = self.engine.on_end_deadline_for(&mut self.model);
        // (Never in ASCII framing: its reply delay is 0, `Config::reply_delay_ticks`.)
        #[cfg(feature = "reply-delay")]
        if end == EndOfFrame::Reply && self.reply_delay != 0 {
            // Processed now, sent when the delay has passed.
            self.tx_len = self.process() as TxIndex;
            if !self.timer.delay(self.reply_delay) {
                self.send_processed();
            }
            return;
        }
        if end == EndOfFrame::Reply {
            let _ = self.driver_enable.set_high();
            let _ = self.led.set_high();
            self.usart.write(self.first_char());
            self.tx_next = 1;
        }
        // Executes what `on_end_deadline` accepted (nothing for the other ends) and, for a
        // reply, appends its CRC; the rest of the reply follows its first character from the
        // data-register-empty interrupt.
        let bytes = if cfg!(feature = "capture-line") { self.process_interruptible() } else { self.process() };
        // Only a reply sets the length: a silence that ended no frame (T3.5 after a character
        // that came in while a reply goes out, on a full-duplex line) leaves the reply on
        // its way as it is.
        let chars = self.reply_chars(bytes);
        if chars != 0 {
            self.tx_len = chars;
            self.usart.start_feeding();
        }
    }

    /// Executes what `on_end_deadline` accepted (`Engine::process`). A model other ports
    /// serve too learns first that the request comes from this USART, and its address
    /// (what it records of a write, [`crate::Write`]).
    #[inline(always)]
    fn process(&mut self) -> usize {
        if M::SHARED {
            self.model.serve_from(crate::Port::Serial(U), self.engine.frame_address());
        }
        self.engine.process(&mut self.model)
    }

    /// [`Running::process`] with interrupts enabled, in a firmware with a capture line
    /// (feature `capture-line`): that line's interrupts send each bit of a reply's first
    /// character and catch each edge on RX while a request is processed, which takes longer
    /// than a bit, whichever line this slave is on. The slave itself is reached by none of
    /// them meanwhile: its line holds back a character received (a master that did not wait
    /// for the reply; the capture line hands it on after, the USART's receive interrupt
    /// waits masked), and this compare unit's interrupt (the silences) waits masked. A model
    /// other ports serve too stays whole: Timer0's overflow interrupt, where the TCP server
    /// runs, waits as well.
    #[inline(always)]
    fn process_interruptible(&mut self) -> usize {
        #[cfg(feature = "capture-line")]
        {
            use crate::avr::reg::{self, TIMSK0};
            use crate::avr::timer::Unit;
            let held = Compare::<C>::FLAG | if M::SHARED { crate::avr::timer::TOIE0 } else { 0 };
            self.usart.hold_received(true);
            TIMSK0.modify(|bits| bits & !held);
            // SAFETY: nothing an interrupt handler reaches is borrowed here but the slave,
            // which none reaches now (above); they return with interrupts disabled.
            unsafe { reg::enable_interrupts() };
            let bytes = self.process();
            // SAFETY: the handler goes on as it began, interrupts disabled.
            unsafe { reg::disable_interrupts() };
            TIMSK0.modify(|bits| bits | held);
            self.usart.hold_received(false);
            bytes
        }
        #[cfg(not(feature = "capture-line"))]
        self.process()
    }

    /// RTU framing: what `passed`, the inter-character gap deadline (T1.5, which marks a
    /// frame that goes on as damaged), or T3.5 of silence, which ends the frame (true). A reply's delay (feature `reply-delay`) that has passed
    /// sends it.
    #[inline(always)]
    fn rtu_ended(&mut self, passed: Passed) -> bool {
        match passed {
            Passed::Nothing => false,
            Passed::Gap => false,
            // A character that arrived while interrupts were held off (this interrupt
            // outranks the receive one) was on the wire before T3.5 expired: the silence
            // starts over, and the receive interrupt, pending, takes the character right
            // after this one.
            Passed::End if self.usart.has_data() => {
                self.timer.restart();
                false
            }
            Passed::End => true,
            #[cfg(feature = "reply-delay")]
            Passed::Delayed => {
                self.send_processed();
                false
            }
        }
    }

    /// The reply's first character: the address, or in ASCII framing `:`.
    #[inline(always)]
    fn first_char(&self) -> u8 {
        self.engine.framing().first_char(self.address())
    }

    /// The address a reply carries: the slave id, or with a model of several ids
    /// ([`DataModel::UNITS`]) the one the request addressed.
    #[inline(always)]
    fn address(&self) -> u8 {
        if M::UNITS {
            self.engine.address()
        } else {
            self.engine.id().get()
        }
    }

    /// Characters on the wire for a reply of `bytes` bytes (at most 255, FC 3 or 4 with 125
    /// registers): as many, or in ASCII framing its frame's (`:`, two hex digits a byte,
    /// CR LF; at most 513).
    #[inline(always)]
    fn reply_chars(&self, bytes: usize) -> TxIndex {
        self.engine.framing().chars(bytes) as TxIndex
    }

    /// Sends a reply processed already (feature `reply-delay`): its delay has passed.
    #[cfg(feature = "reply-delay")]
    fn send_processed(&mut self) {
        let _ = self.driver_enable.set_high();
        let _ = self.led.set_high();
        self.usart.write(self.address());
        self.tx_next = 1;
        self.usart.start_feeding();
    }

    /// USART data register empty: the next character of the reply (its check included).
    #[inline(always)]
    pub(super) fn on_usart_udre(&mut self) {
        let next = self.tx_next;
        self.usart.write(self.engine.reply_char(usize::from(next)));
        self.tx_next = next.wrapping_add(1);
        if self.tx_next == self.tx_len {
            self.usart.last_written();
        }
    }

    /// USART transmit complete: the reply has left the wire.
    #[inline(always)]
    pub(super) fn on_usart_tx(&mut self) {
        self.usart.finished();
        let _ = self.driver_enable.set_low();
        let _ = self.led.set_low();
        self.engine.on_reply_sent();
        #[cfg(feature = "eeprom-settings")]
        self.apply_new_settings();
    }

    /// Switches the USART, Timer0 and the slave id (and with feature `ascii` the framing) to
    /// settings the master wrote, if they are ready (see [`Slave::poll_settings`]); called
    /// when nothing of a reply is left to send.
    #[cfg(feature = "eeprom-settings")]
    #[inline(always)]
    pub(super) fn apply_new_settings(&mut self) {
        if let Some(config) = self.model.take_new_settings() {
            self.usart.configure(config.line());
            self.timer.configure(config.line().timer_plan());
            self.engine.set_id(config.slave_id());
            #[cfg(feature = "reply-delay")]
            {
                self.reply_delay = config.reply_delay_ticks();
            }
            #[cfg(feature = "ascii")]
            set_mode(&mut self.engine, &mut self.timer, config.line());
        }
    }
}

/// The engine and Timer0 in the framing `config` asks for (feature `ascii`).
#[cfg(feature = "ascii")]
fn set_mode<const N: usize, const C: char>(
    engine: &mut Engine<N>,
    timer: &mut FrameTimer<Compare<C>>,
    config: &crate::Line,
) {
    engine.set_ascii(timer.set_mode(config));
}
