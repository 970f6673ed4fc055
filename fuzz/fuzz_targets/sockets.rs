//! The TCP server's socket state machine fed arbitrary chip register contents: every state,
//! event bit, byte count, pointer and received byte comes from the input. The server must
//! never panic (debug assertions on: no overflow), never take more bytes than the chip said
//! it received, never write more than the room the chip said it had, and never write more
//! than its buffer.
#![no_main]

use avr_modbus::internal::tcp::{Server, Serving, Sockets};
use avr_modbus::tcp::Network;
use avr_modbus::Bank;
use libfuzzer_sys::fuzz_target;

/// A chip that answers every question with the input's next bytes (zeros once it ends).
struct Arbitrary<'a> {
    input: &'a [u8],
    /// Per socket: the byte count the chip last said it received, and the RX pointer then.
    received: [(u16, u16); 8],
    /// Per socket: the room the chip last said it had, and the TX pointer then.
    room: [(u16, u16); 8],
}

impl Arbitrary<'_> {
    fn byte(&mut self) -> u8 {
        let (first, rest) = self.input.split_first().map_or((0, &[][..]), |(b, r)| (*b, r));
        self.input = rest;
        first
    }

    fn word(&mut self) -> u16 {
        u16::from_be_bytes([self.byte(), self.byte()])
    }
}

impl Sockets for Arbitrary<'_> {
    fn events(&mut self) -> u8 {
        self.byte()
    }
    fn take_events(&mut self, _s: u8) -> u8 {
        self.byte()
    }
    fn status(&mut self, _s: u8) -> u8 {
        // The states the server tells apart, and anything else.
        [0x00, 0x13, 0x14, 0x17, 0x1C, 0x18, 0x1B, 0x22, self.byte()][usize::from(self.byte() % 9)]
    }
    fn command(&mut self, _s: u8, _command: u8) {}
    fn listen(&mut self, _s: u8, _port: u16) {}
    fn peer(&mut self, _s: u8) -> [u8; 4] {
        [self.byte(), self.byte(), self.byte(), self.byte()]
    }
    fn received(&mut self, s: u8) -> u16 {
        let n = self.word() % 0x900;
        self.received[usize::from(s)].0 = n;
        n
    }
    fn rx_pointer(&mut self, s: u8) -> u16 {
        let p = self.word();
        self.received[usize::from(s)].1 = p;
        p
    }
    fn read(&mut self, s: u8, pointer: u16, buf: &mut [u8]) {
        let (n, start) = self.received[usize::from(s)];
        let end = pointer.wrapping_sub(start) as usize + buf.len();
        assert!(end <= usize::from(n), "read {end} bytes of {n} received");
        for b in buf.iter_mut() {
            *b = self.byte();
        }
    }
    fn take(&mut self, s: u8, pointer: u16) {
        let (n, start) = self.received[usize::from(s)];
        assert!(pointer.wrapping_sub(start) <= n, "took more than was received");
    }
    fn tx_free(&mut self, s: u8) -> u16 {
        let n = self.word() % 0x900;
        self.room[usize::from(s)].0 = n;
        n
    }
    fn tx_pointer(&mut self, s: u8) -> u16 {
        let p = self.word();
        self.room[usize::from(s)].1 = p;
        p
    }
    fn write(&mut self, s: u8, pointer: u16, data: &mut [u8]) {
        let (n, start) = self.room[usize::from(s)];
        let end = pointer.wrapping_sub(start) as usize + data.len();
        assert!(end <= usize::from(n), "wrote {end} bytes into {n} of room");
        assert!(data.len() <= 260);
    }
    fn send(&mut self, s: u8, pointer: u16) {
        let (n, start) = self.room[usize::from(s)];
        assert!(pointer.wrapping_sub(start) <= n);
    }
}

fuzz_target!(|input: &[u8]| {
    let mut bank: Bank<4, 32, 8> = Bank::new();
    let _ = bank.add_range(40001, 20);
    let _ = bank.add_range(1, 40);
    let net = Network::new([2, 0, 0, 0, 0, 1], [10, 0, 0, 2]).allow(&[[10, 0, 0, 9]]).idle_timeout(3);
    let mut chip = Arbitrary { input, received: [(0, 0); 8], room: [(0, 0); 8] };
    let mut small: Server<20> = Server::new();
    let mut large: Server = Server::new();
    let mut round = 0u32;
    while !chip.input.is_empty() && round < 10_000 {
        let second = chip.byte() & 1 == 1;
        if round % 2 == 0 {
            small.poll(&mut chip, &net, &mut Serving(&mut bank), second);
        } else {
            large.poll(&mut chip, &net, &mut Serving(&mut bank), second);
        }
        round += 1;
    }
});
