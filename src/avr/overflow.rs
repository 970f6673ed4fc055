//! Timer0's overflow interrupt (every 1.024 ms, 2.048 ms at 8 MHz), bound by the crate with
//! feature `millis` or `tcp`: `millis()` moves on (`super::clock`), then the TCP role polls
//! its chip, once started (`super::tcp`, `super::gateway`, `super::tcp_client`): the function
//! the role's macro ([`crate::tcp_server!`], `tcp_gateway!`, `tcp_client!`) defines for it,
//! one role per firmware. A firmware with feature `tcp` and no TCP role does not link, the
//! missing symbol's name saying why. Bound here rather than by [`crate::slave!`]: it touches
//! nothing of the serial roles', and a firmware without either feature has no handler at all
//! (the interrupt stays off). The firmware's alone: the host has no AVR interrupt ABI, so the
//! docs built there (`--cfg docsrs`) leave it out.

/// TIMER0_OVF.
#[cfg(target_arch = "avr")]
#[export_name = __chip!(vector TIMER0_OVF)]
unsafe extern "avr-interrupt" fn timer0_overflow() {
    // SAFETY: the overflow interrupt handler, interrupts disabled.
    #[cfg(feature = "millis")]
    unsafe {
        super::clock::advance()
    };
    // SAFETY: as above.
    #[cfg(feature = "tcp")]
    unsafe {
        avr_modbus_feature_tcp_needs_a_tcp_role()
    };
}

#[cfg(all(target_arch = "avr", feature = "tcp"))]
extern "C" {
    /// The TCP role's poll, which its macro defines: [`crate::tcp_server!`] the
    /// [`crate::TcpServer::on_overflow`], `tcp_gateway!` and `tcp_client!` theirs.
    fn avr_modbus_feature_tcp_needs_a_tcp_role();
}
