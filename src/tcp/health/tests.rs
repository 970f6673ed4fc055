//! The health check against a scripted chip, then the server's recovery against the
//! imitation chip (`crate::tcp::fake`).

use super::*;
use crate::slave::bank::Bank;
use crate::tcp::fake::Fake;
use crate::tcp::wiznet::state;
use crate::tcp::Serving;

const NET: Network = Network::new([2, 0, 0, 0, 0, 1], [10, 0, 0, 2]).sockets(4);

impl Watch for Fake {
    fn configured(&mut self) -> bool {
        !self.lost && !self.hung
    }
    fn link(&mut self) -> bool {
        !self.link_down
    }
    fn restart(&mut self, _: &Network) -> bool {
        self.restarts += 1;
        if self.hung {
            return false;
        }
        self.chip_reset();
        self.lost = false;
        true
    }
}

/// A chip that answers the check as the test says.
#[derive(Default)]
struct Script {
    lost: bool,
    answers: bool,
    down: bool,
    restarts: usize,
}

impl Watch for Script {
    fn configured(&mut self) -> bool {
        !self.lost
    }
    fn link(&mut self) -> bool {
        !self.down
    }
    fn restart(&mut self, _: &Network) -> bool {
        self.restarts += 1;
        self.lost = !self.answers;
        self.answers
    }
}

#[test]
fn a_chip_that_keeps_its_settings_and_link_is_served_and_never_reset() {
    let (mut health, mut chip) = (Health::new(), Script::default());
    for _ in 0..3 {
        assert_eq!(health.check(&mut chip, &NET), Verdict::Serve);
    }
    assert_eq!(chip.restarts, 0);
    assert!(health.link_up());
    assert_eq!((health.restarts(), health.losses()), (0, 0));
}

#[test]
fn a_chip_that_lost_its_settings_is_set_up_again_once_and_counted() {
    let (mut health, mut chip) = (Health::new(), Script { lost: true, answers: true, ..Script::default() });
    assert_eq!(health.check(&mut chip, &NET), Verdict::Reopen);
    assert_eq!(health.check(&mut chip, &NET), Verdict::Serve);
    assert_eq!((chip.restarts, health.restarts()), (1, 1));
}

#[test]
fn a_chip_that_does_not_answer_waits_and_is_tried_again_at_each_check() {
    let (mut health, mut chip) = (Health::new(), Script { lost: true, ..Script::default() });
    for tries in 1..=3 {
        assert_eq!(health.check(&mut chip, &NET), Verdict::Wait);
        assert_eq!(chip.restarts, tries);
        assert!(health.is_lost() && !health.link_up());
        assert_eq!(health.restarts(), 0, "a failed try is not a reset");
    }
    chip.answers = true;
    assert_eq!(health.check(&mut chip, &NET), Verdict::Reopen);
    assert!(!health.is_lost() && health.link_up());
    assert_eq!(health.restarts(), 1);
}

#[test]
fn a_link_that_goes_is_counted_once_and_sets_the_chip_up_again_once() {
    let (mut health, mut chip) = (Health::new(), Script { down: true, answers: true, ..Script::default() });
    assert_eq!(health.check(&mut chip, &NET), Verdict::Reopen);
    assert!(!health.link_up());
    assert_eq!(health.check(&mut chip, &NET), Verdict::Serve, "still down: nothing more to close");
    chip.down = false;
    assert_eq!(health.check(&mut chip, &NET), Verdict::Serve, "back up: the sockets already listen");
    assert!(health.link_up());
    chip.down = true;
    assert_eq!(health.check(&mut chip, &NET), Verdict::Reopen);
    assert_eq!(health.losses(), 2);
    assert_eq!(chip.restarts, 2, "each loss set the chip up again: its connections closed");
    assert_eq!(health.restarts(), 0, "counted as losses, not as resets");
}

/// A bank with holding registers 40001-40010.
fn bank() -> Bank<4, 16, 4, 0, 0> {
    let mut bank = Bank::new();
    bank.add_range(40001, 10).unwrap();
    bank
}

/// A read of 40001, transaction `t`.
fn read(t: u8) -> [u8; 12] {
    [0, t, 0, 0, 0, 6, 0xFF, 0x03, 0, 0, 0, 1]
}

/// A server with every socket listening, and a master served on each of sockets 0 and 2.
fn serving(chip: &mut Fake, bank: &mut Bank<4, 16, 4, 0, 0>) -> Server {
    let mut server = Server::new();
    server.poll(chip, &NET, &mut Serving(bank), false);
    for s in [0, 2] {
        chip.connect(s, [10, 0, 0, 9]);
        chip.deliver(s, &read(1));
    }
    server.poll(chip, &NET, &mut Serving(bank), false);
    assert_eq!(server.counters().requests, 2);
    server
}

/// After the check, the poll with `second` (as the AVR layer makes them): every socket
/// listens, and a new master on socket `s` is answered.
fn served_again(server: &mut Server, chip: &mut Fake, bank: &mut Bank<4, 16, 4, 0, 0>, s: usize) {
    server.poll(chip, &NET, &mut Serving(bank), true);
    assert!(chip.socks.iter().all(|sock| sock.status == state::LISTEN), "every socket listens again");
    let before = server.counters().requests;
    chip.connect(s, [10, 0, 0, 7]);
    chip.deliver(s, &read(2));
    server.poll(chip, &NET, &mut Serving(bank), false);
    assert_eq!(server.counters().requests, before + 1);
    assert_eq!(chip.socks[s].sent[1], 2, "the new master's answer");
}

#[test]
fn a_healthy_chip_keeps_its_connections() {
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server = serving(&mut chip, &mut bank);
    assert!(server.check(&mut chip, &NET));
    assert_eq!(chip.socks[0].status, state::ESTABLISHED);
    assert!(!chip.socks[0].reset && !chip.socks[2].reset);
    assert_eq!(chip.restarts, 0);
}

#[test]
fn a_chip_reset_while_serving_is_set_up_again_and_every_socket_listens() {
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server = serving(&mut chip, &mut bank);
    chip.chip_reset();
    assert!(server.check(&mut chip, &NET));
    assert_eq!(chip.restarts, 1);
    assert_eq!(server.counters().chip_resets, 1);
    served_again(&mut server, &mut chip, &mut bank, 2);
    assert!(server.check(&mut chip, &NET));
    assert_eq!(chip.restarts, 1, "set up once");
}

#[test]
fn a_hung_chip_is_not_served_until_it_answers_again() {
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server = serving(&mut chip, &mut bank);
    chip.hung = true;
    for tries in 1..=3 {
        assert!(!server.check(&mut chip, &NET), "not served while it does not answer");
        assert_eq!(chip.restarts, tries);
    }
    assert!(!server.health.link_up());
    assert_eq!(server.counters().chip_resets, 0);
    chip.hung = false;
    assert!(server.check(&mut chip, &NET));
    assert_eq!(server.counters().chip_resets, 1);
    assert!(server.health.link_up());
    served_again(&mut server, &mut chip, &mut bank, 0);
}

#[test]
fn a_link_loss_closes_every_connection_and_the_sockets_listen_for_its_return() {
    let (mut chip, mut bank) = (Fake::default(), bank());
    let mut server = serving(&mut chip, &mut bank);
    chip.link_down = true;
    assert!(server.check(&mut chip, &NET));
    assert!(chip.socks[0].reset && chip.socks[2].reset, "both connections closed (the chip set up again)");
    assert_eq!(server.counters().link_losses, 1);
    assert!(!server.health.link_up());
    server.poll(&mut chip, &NET, &mut Serving(&mut bank), true);
    assert!(chip.socks.iter().all(|sock| sock.status == state::LISTEN));
    assert!(server.check(&mut chip, &NET));
    assert_eq!(server.counters().link_losses, 1, "counted once while it stays down");
    chip.link_down = false;
    assert!(server.check(&mut chip, &NET));
    assert!(server.health.link_up());
    served_again(&mut server, &mut chip, &mut bank, 2);
    assert_eq!((chip.restarts, server.counters().chip_resets), (1, 0), "set up again once, counted as a loss");
}
