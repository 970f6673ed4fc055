//! Link and chip health on the simulated Uno with its simulated Ethernet shield
//! (`examples/tcp_server.rs` as `make tcp-firmware` builds it): the link pulled for 10 s under
//! four masters, the chip reset while they poll, the chip hung and back. Each master keeps
//! polling as a real one does: a read every 10 ms, a new connection when its own is gone or
//! unanswered for a second. Every figure in simulated time; each test prints the time from
//! the fault's end to every master's first answer.

mod sim;

use std::net::{Ipv4Addr, SocketAddrV4};

use sim::{chip_variant_firmware, cycles_to_us, us_to_cycles};
use uno_sim::wiznet::regs::state;
use uno_sim::{vector, Chip, Options, Uno, Wiznet};

/// The firmware's port.
const PORT: u16 = 502;
/// The firmware's address, as the chip holds it (SIPR).
const IP: [u8; 4] = [192, 168, 1, 177];
/// SIPR's place among the common registers, the same on both chips.
const SIPR: u16 = 0x0F;
/// A master's round: a read every 10 ms.
const ROUND_US: u64 = 10_000;
/// How long a master waits for an answer before it makes a new connection.
const PATIENCE_US: u64 = 1_000_000;

/// The TCP server for `chip`, running until every socket listens.
fn boot(chip: Wiznet) -> Uno {
    let elf = chip_variant_firmware(Chip::Atmega328p, 0, &format!("-{chip}"), "tcp_server");
    let mut uno = Uno::load_with(elf, Options::new().wiznet(chip)).unwrap();
    while !all_listen(&uno) {
        assert!(uno.now() < us_to_cycles(50_000), "{chip}: the sockets never listened");
        uno.run_for(us_to_cycles(100)).unwrap();
    }
    uno
}

fn all_listen(uno: &Uno) -> bool {
    let chip = uno.wiznet().unwrap();
    (0..chip.socket_count()).all(|n| chip.status(n) == state::LISTEN)
}

/// A read of 30001 (the seconds the main loop counted), transaction `t`: MBAP header, FC 4.
fn read(t: u16) -> Vec<u8> {
    let [t0, t1] = t.to_be_bytes();
    vec![t0, t1, 0, 0, 0, 6, 1, 0x04, 0, 0, 0, 1]
}

/// One master: its connection (socket and the connection's id), the request it waits for.
struct Master {
    who: u8,
    conn: Option<(usize, u64)>,
    asked: Option<(u16, u64)>,
    transaction: u16,
    /// The cycle of each answer.
    answers: Vec<u64>,
    /// The last answer's value of 30001.
    seconds: u16,
}

impl Master {
    fn new(who: u8) -> Master {
        Master { who, conn: None, asked: None, transaction: 0, answers: Vec::new(), seconds: 0 }
    }

    fn peer(&self) -> SocketAddrV4 {
        SocketAddrV4::new(Ipv4Addr::new(192, 168, 1, 10 + self.who), 40000 + u16::from(self.who))
    }

    /// One round at the chip: the answer taken, a lost connection dropped, a new one made,
    /// the next request sent.
    fn round(&mut self, uno: &mut Uno) {
        let now = uno.now();
        let chip = uno.wiznet_mut().unwrap();
        if let Some((n, id)) = self.conn {
            let conn = chip.connection(n).filter(|c| c.id() == id);
            if !conn.is_some_and(|c| !c.closed()) {
                self.conn = None;
                self.asked = None;
            } else if let Some((t, at)) = self.asked {
                let reply = chip.take_sent(n);
                if reply.len() == 11 && reply[..2] == t.to_be_bytes() {
                    self.answers.push(now);
                    self.seconds = u16::from_be_bytes([reply[9], reply[10]]);
                    self.asked = None;
                } else if now - at > us_to_cycles(PATIENCE_US) {
                    // Unanswered: the master gives this connection up (its RST would not
                    // arrive while the link is down; it reaches the chip otherwise).
                    chip.peer_reset(n);
                    self.conn = None;
                    self.asked = None;
                }
            }
        }
        if self.conn.is_none() {
            if let Some(n) = chip.connect(PORT, self.peer()) {
                self.conn = Some((n, chip.connection(n).unwrap().id()));
            }
        }
        if let (Some((n, _)), None) = (self.conn, self.asked) {
            self.transaction = self.transaction.wrapping_add(1);
            chip.deliver(n, &read(self.transaction));
            self.asked = Some((self.transaction, now));
        }
    }

    /// The first answer at or after `cycle`.
    fn first_answer_after(&self, cycle: u64) -> Option<u64> {
        self.answers.iter().copied().find(|&a| a >= cycle)
    }
}

/// Runs the masters for `us` of simulated time, a round each every 10 ms; `each` runs after
/// every round.
fn run(uno: &mut Uno, masters: &mut [Master], us: u64, mut each: impl FnMut(&mut Uno)) {
    for _ in 0..us / ROUND_US {
        for m in masters.iter_mut() {
            m.round(uno);
        }
        uno.run_for(us_to_cycles(ROUND_US)).unwrap();
        each(uno);
    }
}

/// Four masters polling, each answered by now.
fn four_masters(uno: &mut Uno) -> Vec<Master> {
    let mut masters: Vec<Master> = (0..4).map(Master::new).collect();
    run(uno, &mut masters, 200_000, |_| {});
    assert!(masters.iter().all(|m| m.answers.len() > 10), "every master served before the fault");
    masters
}

/// Runs until every master has an answer after `since` (at most `limit_us`); returns each
/// one's time from `since` to it, in ms, and prints them.
fn recovered(uno: &mut Uno, masters: &mut [Master], since: u64, limit_us: u64, what: &str) -> Vec<f64> {
    let until = uno.now() + us_to_cycles(limit_us);
    while masters.iter().any(|m| m.first_answer_after(since).is_none()) {
        assert!(uno.now() < until, "{what}: a master not served again within {limit_us} µs");
        run(uno, masters, ROUND_US, |_| {});
    }
    let times: Vec<f64> =
        masters.iter().map(|m| cycles_to_us(m.first_answer_after(since).unwrap() - since) / 1000.0).collect();
    eprintln!("{what}: every master served again after {times:.0?} ms");
    times
}

#[test]
fn a_link_pulled_for_10_s_frees_every_socket_and_four_masters_are_served_again() {
    let mut uno = boot(Wiznet::W5500);
    let mut masters = four_masters(&mut uno);
    let pulled = uno.now();
    uno.wiznet_mut().unwrap().set_link(false);
    // The once-a-second check sees the link gone: every connection closed, every socket
    // listening again within a second and a bit.
    let mut freed = None;
    run(&mut uno, &mut masters, 10_000_000, |uno| {
        if freed.is_none() && all_listen(uno) {
            freed = Some(uno.now());
        }
    });
    let freed = freed.expect("the sockets were never freed while the link was down");
    eprintln!("w5500: link down, every socket listening again after {:.0} ms", cycles_to_us(freed - pulled) / 1000.0);
    assert!(
        freed - pulled < us_to_cycles(1_200_000),
        "sockets freed {} µs after the link went",
        cycles_to_us(freed - pulled)
    );
    assert!(all_listen(&uno), "the sockets still listen after 10 s without a link");
    assert!(
        masters.iter().all(|m| m.first_answer_after(pulled + us_to_cycles(ROUND_US)).is_none()),
        "nothing answered"
    );
    let back = uno.now();
    uno.wiznet_mut().unwrap().set_link(true);
    let times = recovered(&mut uno, &mut masters, back, 2_000_000, "w5500, link back");
    assert!(times.iter().all(|&ms| ms < 100.0), "{times:?}");
}

#[test]
fn a_link_that_flaps_for_6_s_leaves_no_socket_held_and_the_seconds_counted() {
    let mut uno = boot(Wiznet::W5500);
    let mut masters = four_masters(&mut uno);
    let seconds_before = masters[0].seconds;
    // Down 300 ms, up 400 ms, for 6 s: some checks see the link down, some up, some
    // never see the flap at all.
    let started = uno.now();
    let mut up = true;
    let mut toggles = 0;
    // The down phases in which every socket was freed (the check fell in them).
    let mut freed = std::collections::BTreeSet::new();
    run(&mut uno, &mut masters, 6_020_000, |uno| {
        let since = cycles_to_us(uno.now() - started) as u64;
        if !up && all_listen(uno) {
            freed.insert(since / 700_000);
        }
        let want_up = since % 700_000 >= 300_000;
        if want_up != up {
            up = want_up;
            toggles += 1;
            uno.wiznet_mut().unwrap().set_link(up);
        }
    });
    assert!(toggles >= 16, "the link flapped {toggles} times");
    // A check once a second falls in a 300 ms down phase now and then: each time, every
    // connection is closed (its master is gone with the link) and the sockets listen.
    eprintln!("w5500, link flapping: every socket freed in down phases {freed:?}");
    assert!(freed.len() >= 2, "sockets freed in only {} of the 9 down phases", freed.len());
    uno.wiznet_mut().unwrap().set_link(true);
    let back = uno.now();
    // Every socket either serves a master or listens: none is left closed or half-open.
    let times = recovered(&mut uno, &mut masters, back, 2_500_000, "w5500, link flapping for 6 s");
    let chip = uno.wiznet().unwrap();
    for n in 0..chip.socket_count() {
        assert!(
            matches!(chip.status(n), state::LISTEN | state::ESTABLISHED),
            "socket {n} left in state {:#04x}",
            chip.status(n)
        );
    }
    assert!(times.iter().all(|&ms| ms < 2_000.0), "{times:?}");
    // The main loop was never held: its seconds went on through the flapping.
    run(&mut uno, &mut masters, 100_000, |_| {});
    let counted = masters[0].seconds.wrapping_sub(seconds_before);
    assert!((6..=9).contains(&counted), "the main loop counted {counted} s over about 8 s");
}

#[test]
fn a_chip_reset_while_four_masters_poll_is_set_up_again_and_every_master_served() {
    for chip in [Wiznet::W5100, Wiznet::W5500] {
        let mut uno = boot(chip);
        let mut masters = four_masters(&mut uno);
        let reset = uno.now();
        uno.wiznet_mut().unwrap().reset();
        assert_eq!(ip(&mut uno), [0; 4], "{chip}: the chip's defaults");
        let times = recovered(&mut uno, &mut masters, reset, 2_000_000, &format!("{chip}, chip reset"));
        assert_eq!(ip(&mut uno), IP, "{chip}: its address given again");
        assert!(times.iter().all(|&ms| ms < 1_200.0), "{chip}: {times:?}");
    }
}

fn ip(uno: &mut Uno) -> [u8; 4] {
    let chip = uno.wiznet_mut().unwrap();
    std::array::from_fn(|i| chip.common_register(SIPR + i as u16))
}

#[test]
fn a_hung_chip_blocks_nothing_and_is_set_up_again_once_it_answers() {
    for (chip, stuck) in [(Wiznet::W5100, 0xFF), (Wiznet::W5500, 0x00)] {
        let mut uno = boot(chip);
        let mut masters = four_masters(&mut uno);
        let seconds_before = masters[0].seconds;
        let hung = uno.now();
        uno.wiznet_mut().unwrap().hang(stuck);
        // 1.6 s hung (found at the first check, tried again at the next): the Timer0 overflow's handler (the poll, the checks, the tries to set
        // the chip up again) never holds the CPU long, and leaves the main loop most of it.
        uno.reset_isr_stats();
        let (mut worst_share, mut window) = (0.0f64, (uno.now(), 0u64));
        run(&mut uno, &mut masters, 1_600_000, |uno| {
            let cycles = uno.isr_stats(vector::TIMER0_OVF).cycles;
            if uno.now() - window.0 >= us_to_cycles(100_000) {
                let share = (cycles - window.1) as f64 / (uno.now() - window.0) as f64;
                worst_share = worst_share.max(share);
                window = (uno.now(), cycles);
            }
        });
        let stats = uno.isr_stats(vector::TIMER0_OVF);
        let hung_for = uno.now() - hung;
        eprintln!(
            "{chip} hung at {stuck:#04x}: the poll's handler {:.1} % of the CPU (worst 100 ms {:.1} %), longest run {:.0} µs",
            100.0 * stats.cycles as f64 / hung_for as f64,
            100.0 * worst_share,
            cycles_to_us(stats.max_cycles)
        );
        assert!(worst_share < 0.5, "{chip}: the handler took {:.0} % of 100 ms", 100.0 * worst_share);
        assert!(stats.max_cycles < us_to_cycles(20_000), "{chip}: one run of {} µs", cycles_to_us(stats.max_cycles));
        let back = uno.now();
        uno.wiznet_mut().unwrap().unhang();
        let times =
            recovered(&mut uno, &mut masters, back, 2_000_000, &format!("{chip}, hung at {stuck:#04x} then back"));
        assert!(times.iter().all(|&ms| ms < 1_200.0), "{chip}: {times:?}");
        assert_eq!(ip(&mut uno), IP, "{chip}");
        // The main loop kept counting its seconds meanwhile.
        let counted = masters[0].seconds.wrapping_sub(seconds_before);
        assert!(counted >= 1, "{chip}: the main loop counted {counted} s over {} s", cycles_to_us(hung_for) / 1e6);
    }
}

// ---- the client (`examples/tcp_client_check.rs`): its one connection made again ------------

/// The client firmware for `chip`, its connection to the server accepted.
fn client(chip: Wiznet) -> Uno {
    let variant = if chip == Wiznet::W5500 { "-tcp-client-w5500" } else { "-tcp-client" };
    let elf = chip_variant_firmware(Chip::Atmega328p, 0, variant, "tcp_client_check");
    let mut uno = Uno::load_with(elf, Options::new().wiznet(chip)).unwrap();
    dialled(&mut uno, 0, 50_000, "the first SYN");
    uno
}

/// Runs until the client's SYN is out (at most `limit_us`), accepts it and runs until the
/// firmware says it is connected; returns the time to the SYN, in ms.
fn dialled(uno: &mut Uno, since: u64, limit_us: u64, what: &str) -> f64 {
    let until = uno.now() + us_to_cycles(limit_us);
    while uno.wiznet().unwrap().connecting().is_empty() {
        assert!(uno.now() < until, "{what}: no SYN within {limit_us} µs");
        uno.run_for(us_to_cycles(1000)).unwrap();
    }
    let syn = uno.now();
    let n = uno.wiznet().unwrap().connecting()[0].0;
    assert!(uno.wiznet_mut().unwrap().accept_connect(n));
    while uno.read_symbol("TCP_OUTCOME").unwrap()[3] != 1 {
        assert!(uno.now() < until + us_to_cycles(10_000), "{what}: not connected");
        uno.run_for(us_to_cycles(1000)).unwrap();
    }
    cycles_to_us(syn - since) / 1000.0
}

#[test]
fn the_client_connects_again_after_a_chip_reset_and_after_the_link_comes_back() {
    for chip in [Wiznet::W5100, Wiznet::W5500] {
        let mut uno = client(chip);
        uno.run_for(us_to_cycles(100_000)).unwrap();
        let reset = uno.now();
        uno.wiznet_mut().unwrap().reset();
        let ms = dialled(&mut uno, reset, 1_200_000, &format!("{chip}, chip reset"));
        assert_eq!(ip(&mut uno), IP, "{chip}: its address given again");
        eprintln!("tcp client ({chip}), chip reset: connecting again after {ms:.0} ms");
    }
    let mut uno = client(Wiznet::W5500);
    uno.wiznet_mut().unwrap().set_link(false);
    // The check closes the connection; the client's SYNs go nowhere meanwhile.
    uno.run_for(us_to_cycles(1_500_000)).unwrap();
    assert_eq!(uno.read_symbol("TCP_OUTCOME").unwrap()[3], 0, "the connection closed with the link");
    let back = uno.now();
    uno.wiznet_mut().unwrap().set_link(true);
    let ms = dialled(&mut uno, back, 3_500_000, "w5500, link back");
    eprintln!("tcp client (w5500), link back: connecting again after {ms:.0} ms");
}

// ---- the gateway (`examples/tcp_gateway.rs`, W5100): its own registers 9–11 ----------------

/// Registers 9–11 of the gateway's own unit (255): the chip's resets, the link's losses, 1
/// while the link is up; asked on a new connection (at most 200 ms).
fn gateway_health(uno: &mut Uno, t: u16) -> Vec<u16> {
    let n = uno.wiznet_mut().unwrap().connect(PORT, SocketAddrV4::new(Ipv4Addr::new(192, 168, 1, 9), 41000 + t));
    let n = n.expect("a socket listens");
    let [t0, t1] = t.to_be_bytes();
    uno.wiznet_mut().unwrap().deliver(n, &[t0, t1, 0, 0, 0, 6, 0xFF, 0x04, 0, 9, 0, 3]);
    let mut got = Vec::new();
    let until = uno.now() + us_to_cycles(200_000);
    while got.len() < 15 && uno.now() < until {
        uno.run_for(us_to_cycles(1000)).unwrap();
        got.extend(uno.wiznet_mut().unwrap().take_sent(n));
    }
    assert_eq!(got.get(..9), Some(&[t0, t1, 0, 0, 0, 9, 0xFF, 0x04, 6][..]), "{got:02X?}");
    uno.wiznet_mut().unwrap().peer_fin(n);
    got[9..].chunks(2).map(|c| u16::from_be_bytes([c[0], c[1]])).collect()
}

#[test]
fn the_gateway_counts_a_chip_reset_at_its_own_registers_and_serves_again() {
    let elf = chip_variant_firmware(Chip::Atmega328p, 0, "-tcp-gateway", "tcp_gateway");
    let mut uno = Uno::load_with(elf, Options::new().wiznet(Wiznet::W5100)).unwrap();
    while !all_listen(&uno) {
        assert!(uno.now() < us_to_cycles(100_000), "the sockets never listened");
        uno.run_for(us_to_cycles(100)).unwrap();
    }
    assert_eq!(gateway_health(&mut uno, 1), [0, 0, 1], "no reset, no loss, the link up");
    let reset = uno.now();
    uno.wiznet_mut().unwrap().reset();
    while !all_listen(&uno) {
        assert!(uno.now() - reset < us_to_cycles(1_200_000), "not set up again within 1.2 s");
        uno.run_for(us_to_cycles(1000)).unwrap();
    }
    eprintln!(
        "tcp_gateway (w5100), chip reset: listening again after {:.0} ms",
        cycles_to_us(uno.now() - reset) / 1000.0
    );
    assert_eq!(ip(&mut uno), IP, "its address given again");
    assert_eq!(gateway_health(&mut uno, 2), [1, 0, 1], "one reset counted at register 9");
}
