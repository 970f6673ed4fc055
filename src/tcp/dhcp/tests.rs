//! The client's exchanges scripted: every answer a server (or a stranger) can send, every
//! timer, byte by byte.

use super::*;

const MAC_ADDRESS: [u8; 6] = [0x02, 0xAB, 0xCD, 0x00, 0x00, 0x01];
const NET: Network = Network::new(MAC_ADDRESS, [192, 168, 7, 50]).gateway([192, 168, 7, 1]).dhcp(3, "plc-7");
const SERVER: [u8; 4] = [10, 0, 0, 1];
const OFFERED: [u8; 4] = [10, 0, 0, 77];

impl Datagram for &[u8] {
    fn len(&self) -> u16 {
        <[u8]>::len(self) as u16
    }
    fn read(&mut self, at: u16, buf: &mut [u8]) {
        let at = usize::from(at);
        buf.copy_from_slice(&self[at..at + buf.len()]);
    }
}

fn ip_of(addresses: &[u8; ADDRESSES]) -> [u8; 4] {
    addresses[IP..].try_into().unwrap()
}

fn client(net: Network) -> Dhcp {
    Dhcp::new(&net, net.dhcp.unwrap())
}

/// The message due, whole.
fn sent(dhcp: &Dhcp) -> Vec<u8> {
    // Stale bytes where the message goes: every one must be written.
    let mut out = vec![0xEE; 600];
    let mut buf = [0; MESSAGE_BUF];
    let len = dhcp
        .message(&mut buf, &mut |at, piece| out[usize::from(at)..usize::from(at) + piece.len()].copy_from_slice(piece));
    out.truncate(usize::from(len));
    out
}

/// Option `code`'s value in a message, if there.
fn option_of(message: &[u8], code: u8) -> Option<Vec<u8>> {
    let mut at = 240;
    while at < message.len() && message[at] != 255 {
        if message[at] == 0 {
            at += 1;
            continue;
        }
        let n = usize::from(message[at + 1]);
        if message[at] == code {
            return Some(message[at + 2..at + 2 + n].to_vec());
        }
        at += 2 + n;
    }
    None
}

/// A server's reply: op 2, the client's xid and MAC, `yiaddr`, then the options.
fn reply(xid: [u8; 4], yiaddr: [u8; 4], options: &[(u8, &[u8])]) -> Vec<u8> {
    let mut m = vec![0; 240];
    m[..4].copy_from_slice(&[2, 1, 6, 0]);
    m[4..8].copy_from_slice(&xid);
    m[16..20].copy_from_slice(&yiaddr);
    m[20..24].copy_from_slice(&SERVER);
    m[28..34].copy_from_slice(&MAC_ADDRESS);
    m[236..240].copy_from_slice(&COOKIE);
    for (code, value) in options {
        m.push(*code);
        m.push(value.len() as u8);
        m.extend_from_slice(value);
    }
    m.push(255);
    m
}

fn xid_of(dhcp: &Dhcp) -> [u8; 4] {
    let m = sent(dhcp);
    [m[4], m[5], m[6], m[7]]
}

fn offer(dhcp: &Dhcp, lease: u32) -> Vec<u8> {
    reply(
        xid_of(dhcp),
        OFFERED,
        &[(53, &[2]), (54, &SERVER), (51, &lease.to_be_bytes()), (1, &[255, 255, 0, 0]), (3, &[10, 0, 0, 254])],
    )
}

fn ack(dhcp: &Dhcp, lease: u32) -> Vec<u8> {
    reply(xid_of(dhcp), OFFERED, &[(53, &[5]), (54, &SERVER), (51, &lease.to_be_bytes())])
}

fn nak(dhcp: &Dhcp) -> Vec<u8> {
    reply(xid_of(dhcp), [0; 4], &[(53, &[6]), (54, &SERVER)])
}

fn give(dhcp: &mut Dhcp, message: &[u8]) -> bool {
    let mut datagram = message;
    dhcp.receive(&mut datagram)
}

fn refusals(dhcp: &Dhcp) -> u32 {
    let c = dhcp.counters();
    [
        c.short,
        c.not_reply,
        c.other_client,
        c.other_xid,
        c.malformed,
        c.missing,
        c.bad_lease,
        c.bad_address,
        c.unexpected,
    ]
    .iter()
    .map(|&n| u32::from(n))
    .sum()
}

/// A client bound to OFFERED with a lease of `lease` seconds.
fn bound(lease: u32) -> Dhcp {
    let mut dhcp = client(NET);
    assert!(dhcp.second());
    let offer = offer(&dhcp, lease);
    assert!(give(&mut dhcp, &offer));
    let ack = ack(&dhcp, lease);
    assert!(!give(&mut dhcp, &ack));
    assert_eq!(dhcp.state, DhcpState::Bound);
    dhcp
}

fn ip_now(dhcp: &Dhcp) -> [u8; 4] {
    ip_of(&dhcp.addresses())
}

#[test]
fn discover_is_a_broadcast_request_from_this_mac_with_host_name_and_client_id() {
    let mut dhcp = client(NET);
    assert_eq!(ip_now(&dhcp), [0; 4], "no address before a lease");
    assert!(dhcp.second());
    let m = sent(&dhcp);
    assert_eq!(m.len(), 300);
    assert_eq!(&m[..4], &[1, 1, 6, 0], "op request, Ethernet, 6-byte MAC, no hops");
    assert_eq!(&m[10..12], &[0x80, 0], "broadcast flag");
    assert_eq!(&m[12..16], &[0; 4], "no ciaddr");
    assert_eq!(&m[28..34], &MAC_ADDRESS);
    assert!(m[34..236].iter().all(|&b| b == 0));
    assert_eq!(&m[236..240], &COOKIE);
    assert_eq!(option_of(&m, 53), Some(vec![1]), "DISCOVER");
    assert_eq!(option_of(&m, 12), Some(b"plc-7".to_vec()));
    assert_eq!(option_of(&m, 61), Some([&[1][..], &MAC_ADDRESS].concat()));
    assert_eq!(option_of(&m, 55), Some(vec![1, 3, 51]));
    assert_eq!(option_of(&m, 50), None);
    assert_eq!(dhcp.destination(), [255; 4]);
}

#[test]
fn an_offer_is_requested_with_its_address_and_server_then_the_ack_applies_it() {
    let mut dhcp = client(NET);
    dhcp.second();
    let offer = offer(&dhcp, 3600);
    assert!(give(&mut dhcp, &offer), "the REQUEST is due at once");
    let m = sent(&dhcp);
    assert_eq!(option_of(&m, 53), Some(vec![3]));
    assert_eq!(option_of(&m, 50), Some(OFFERED.to_vec()));
    assert_eq!(option_of(&m, 54), Some(SERVER.to_vec()));
    assert_eq!(&m[12..16], &[0; 4], "no ciaddr while requesting");
    assert_eq!(dhcp.destination(), [255; 4]);
    assert_eq!(ip_now(&dhcp), [0; 4], "an offer is not a lease");
    let ack = ack(&dhcp, 3600);
    give(&mut dhcp, &ack);
    let a = dhcp.addresses();
    assert_eq!(ip_of(&a), OFFERED);
    assert_eq!(&a[SUBNET..SUBNET + 4], &[255, 255, 0, 0], "the offer's subnet");
    assert_eq!(&a[GATEWAY..GATEWAY + 4], &[10, 0, 0, 254], "the offer's router");
    assert_eq!(&a[MAC..MAC + 6], &MAC_ADDRESS);
    assert_eq!(dhcp.counters().leases, 1);
    assert_eq!(dhcp.status().remaining, 3600);
    assert_eq!(refusals(&dhcp), 0);
}

#[test]
fn without_subnet_and_router_the_networks_own_are_kept() {
    let mut dhcp = client(NET);
    dhcp.second();
    let offer = reply(xid_of(&dhcp), OFFERED, &[(53, &[2]), (54, &SERVER), (51, &[0, 0, 1, 0])]);
    give(&mut dhcp, &offer);
    let ack = ack(&dhcp, 256);
    give(&mut dhcp, &ack);
    let a = dhcp.addresses();
    assert_eq!(&a[..8], &[192, 168, 7, 1, 255, 255, 255, 0]);
}

#[test]
fn the_lease_is_renewed_at_t1_by_unicast_and_rebound_at_t2_by_broadcast() {
    let mut dhcp = bound(1000);
    for _ in 1..500 {
        assert!(!dhcp.second(), "nothing sent before T1");
    }
    assert!(dhcp.second(), "T1 = 500 s");
    assert_eq!(dhcp.state, DhcpState::Renewing);
    let m = sent(&dhcp);
    assert_eq!(dhcp.destination(), SERVER, "unicast to the server");
    assert_eq!(&m[12..16], &OFFERED, "ciaddr");
    assert_eq!(option_of(&m, 53), Some(vec![3]));
    assert_eq!(option_of(&m, 50), None, "no requested address while renewing");
    assert_eq!(option_of(&m, 54), None, "no server id while renewing");
    assert_eq!(ip_now(&dhcp), OFFERED, "the address is used while renewing");
    // Unanswered: again after half the time to T2, (875 − 500)/2 = 187 s, then 94 s, then
    // at least 60 s; rebinding at T2 = 875 s.
    let times: Vec<u32> = (501..=875).filter(|_| dhcp.second()).collect();
    assert_eq!(times, [687, 781, 841, 875]);
    assert_eq!(dhcp.state, DhcpState::Rebinding);
    assert_eq!(dhcp.destination(), [255; 4]);
    assert_eq!(&sent(&dhcp)[12..16], &OFFERED);
    // A rebinding ACK from another server is taken.
    let other = reply(xid_of(&dhcp), OFFERED, &[(53, &[5]), (54, &[10, 0, 0, 2]), (51, &1000u32.to_be_bytes())]);
    give(&mut dhcp, &other);
    assert_eq!(dhcp.state, DhcpState::Bound);
    assert_eq!(dhcp.status().remaining, 1000);
    assert_eq!(dhcp.server, [10, 0, 0, 2]);
    assert_eq!(dhcp.counters().leases, 2);
}

#[test]
fn a_renewal_ack_keeps_the_address_and_restarts_the_lease() {
    let mut dhcp = bound(100);
    while !dhcp.second() {}
    assert_eq!(dhcp.age, 50);
    let before = dhcp.addresses();
    let ack = ack(&dhcp, 100);
    give(&mut dhcp, &ack);
    assert_eq!(dhcp.addresses(), before);
    assert_eq!((dhcp.state, dhcp.age, dhcp.status().remaining), (DhcpState::Bound, 0, 100));
}

#[test]
fn t1_and_t2_are_taken_from_options_58_and_59() {
    let mut dhcp = client(NET);
    dhcp.second();
    let offer = offer(&dhcp, 1000);
    give(&mut dhcp, &offer);
    let ack = reply(
        xid_of(&dhcp),
        OFFERED,
        &[
            (53, &[5]),
            (54, &SERVER),
            (51, &1000u32.to_be_bytes()),
            (58, &100u32.to_be_bytes()),
            (59, &200u32.to_be_bytes()),
        ],
    );
    give(&mut dhcp, &ack);
    assert_eq!((dhcp.t1, dhcp.t2), (100, 200));
}

#[test]
fn t1_and_t2_out_of_order_fall_back_to_half_and_seven_eighths() {
    for (t1, t2) in [(300u32, 200u32), (100, 2000), (2000, 3000)] {
        let mut dhcp = client(NET);
        dhcp.second();
        let offer = offer(&dhcp, 1000);
        give(&mut dhcp, &offer);
        let ack = reply(
            xid_of(&dhcp),
            OFFERED,
            &[
                (53, &[5]),
                (54, &SERVER),
                (51, &1000u32.to_be_bytes()),
                (58, &t1.to_be_bytes()),
                (59, &t2.to_be_bytes()),
            ],
        );
        give(&mut dhcp, &ack);
        assert_eq!((dhcp.t1, dhcp.t2), (500, 875), "T1 {t1}, T2 {t2}");
    }
}

#[test]
fn at_expiry_the_address_is_given_up_and_discovery_starts_again() {
    let mut dhcp = bound(20);
    for _ in 0..19 {
        dhcp.second();
    }
    assert_eq!(ip_now(&dhcp), OFFERED);
    assert!(dhcp.second(), "a DISCOVER at once");
    assert_eq!(ip_now(&dhcp), [0; 4]);
    assert_eq!(dhcp.state, DhcpState::Selecting);
    assert_eq!(dhcp.counters().expired, 1);
    assert_eq!(option_of(&sent(&dhcp), 53), Some(vec![1]));
    assert_eq!(dhcp.status().remaining, 0);
}

#[test]
fn an_infinite_lease_is_never_renewed_nor_lost() {
    let mut dhcp = bound(INFINITE);
    assert!((0..2_000_000).all(|_| !dhcp.second()));
    assert_eq!(ip_now(&dhcp), OFFERED);
    assert_eq!(dhcp.status().remaining, INFINITE);
}

#[test]
fn a_lease_of_0_is_refused_in_an_offer_and_an_ack() {
    let mut dhcp = client(NET);
    dhcp.second();
    let offer0 = offer(&dhcp, 0);
    assert!(!give(&mut dhcp, &offer0));
    assert_eq!((dhcp.state, dhcp.counters().bad_lease), (DhcpState::Selecting, 1));
    let offer = offer(&dhcp, 60);
    give(&mut dhcp, &offer);
    let ack0 = ack(&dhcp, 0);
    give(&mut dhcp, &ack0);
    assert_eq!((dhcp.state, dhcp.counters().bad_lease), (DhcpState::Requesting, 2));
    assert_eq!(ip_now(&dhcp), [0; 4]);
}

#[test]
fn a_nak_while_requesting_restarts_from_discover_with_a_new_xid() {
    let mut dhcp = client(NET);
    dhcp.second();
    let first = xid_of(&dhcp);
    let offer = offer(&dhcp, 60);
    give(&mut dhcp, &offer);
    let nak = nak(&dhcp);
    assert!(!give(&mut dhcp, &nak));
    assert_eq!((dhcp.state, dhcp.counters().naks), (DhcpState::Selecting, 1));
    assert!(dhcp.second(), "the DISCOVER at the next second");
    assert_ne!(xid_of(&dhcp), first);
}

#[test]
fn a_nak_while_renewing_gives_the_address_up_at_once() {
    let mut dhcp = bound(100);
    while !dhcp.second() {}
    let nak = nak(&dhcp);
    give(&mut dhcp, &nak);
    assert_eq!(ip_now(&dhcp), [0; 4]);
    assert_eq!(dhcp.state, DhcpState::Selecting);
}

#[test]
fn a_nak_or_ack_from_another_server_while_requesting_is_ignored() {
    let mut dhcp = client(NET);
    dhcp.second();
    let offer = offer(&dhcp, 60);
    give(&mut dhcp, &offer);
    let other_nak = reply(xid_of(&dhcp), [0; 4], &[(53, &[6]), (54, &[10, 0, 0, 9])]);
    let other_ack = reply(xid_of(&dhcp), OFFERED, &[(53, &[5]), (54, &[10, 0, 0, 9]), (51, &[0, 0, 0, 60])]);
    give(&mut dhcp, &other_nak);
    give(&mut dhcp, &other_ack);
    assert_eq!((dhcp.state, dhcp.counters().unexpected), (DhcpState::Requesting, 2));
}

#[test]
fn an_ack_for_another_address_than_the_one_asked_is_refused() {
    let mut dhcp = client(NET);
    dhcp.second();
    let offer = offer(&dhcp, 60);
    give(&mut dhcp, &offer);
    let ack = reply(xid_of(&dhcp), [10, 0, 0, 78], &[(53, &[5]), (54, &SERVER), (51, &[0, 0, 0, 60])]);
    give(&mut dhcp, &ack);
    assert_eq!((dhcp.state, dhcp.counters().bad_address), (DhcpState::Requesting, 1));
    // Nor while renewing.
    let mut dhcp = bound(100);
    while !dhcp.second() {}
    let ack = reply(xid_of(&dhcp), [10, 0, 0, 78], &[(53, &[5]), (54, &SERVER), (51, &[0, 0, 0, 60])]);
    give(&mut dhcp, &ack);
    assert_eq!((dhcp.state, ip_now(&dhcp), dhcp.counters().bad_address), (DhcpState::Renewing, OFFERED, 1));
}

#[test]
fn offers_of_addresses_no_host_may_have_are_refused() {
    for address in [[0, 0, 0, 0], [255, 255, 255, 255], [127, 0, 0, 1], [224, 0, 0, 1], [240, 1, 2, 3]] {
        let mut dhcp = client(NET);
        dhcp.second();
        let offer = reply(xid_of(&dhcp), address, &[(53, &[2]), (54, &SERVER), (51, &[0, 0, 0, 60])]);
        assert!(!give(&mut dhcp, &offer));
        assert_eq!((dhcp.state, dhcp.counters().bad_address), (DhcpState::Selecting, 1), "{address:?}");
    }
}

#[test]
fn answers_for_another_client_or_exchange_or_not_replies_are_refused_each_by_its_counter() {
    let mut dhcp = client(NET);
    dhcp.second();
    let good = offer(&dhcp, 60);
    type Case = (Vec<u8>, fn(&DhcpCounters) -> u16);
    let mut cases: Vec<Case> = Vec::new();
    let mut m = good.clone();
    m[33] ^= 1;
    cases.push((m, |c| c.other_client));
    let mut m = good.clone();
    m[1] = 6;
    cases.push((m, |c| c.other_client));
    let mut m = good.clone();
    m[2] = 8;
    cases.push((m, |c| c.other_client));
    let mut m = good.clone();
    m[7] ^= 0x80;
    cases.push((m, |c| c.other_xid));
    let mut m = good.clone();
    m[0] = 1;
    cases.push((m, |c| c.not_reply));
    let mut m = good.clone();
    m[239] = 0;
    cases.push((m, |c| c.malformed));
    cases.push((good[..239].to_vec(), |c| c.short));
    for (i, (message, counter)) in cases.iter().enumerate() {
        let before = counter(&dhcp.counters());
        assert!(!give(&mut dhcp, message));
        assert_eq!(counter(&dhcp.counters()), before + 1, "case {i}");
        assert_eq!(dhcp.state, DhcpState::Selecting);
    }
    assert_eq!(refusals(&dhcp), cases.len() as u32);
    assert!(give(&mut dhcp, &good), "the right one is still taken");
}

#[test]
fn missing_options_are_refused() {
    let mut dhcp = client(NET);
    dhcp.second();
    let xid = xid_of(&dhcp);
    let lease = 60u32.to_be_bytes();
    for options in [
        &[(54u8, &SERVER[..]), (51, &lease[..])][..],
        &[(53, &[2][..]), (51, &lease[..])],
        &[(53, &[2][..]), (54, &SERVER[..])],
    ] {
        assert!(!give(&mut dhcp, &reply(xid, OFFERED, options)));
    }
    assert_eq!((dhcp.counters().missing, refusals(&dhcp)), (3, 3));
    let offer = offer(&dhcp, 60);
    give(&mut dhcp, &offer);
    // An ACK without a lease time.
    give(&mut dhcp, &reply(xid, OFFERED, &[(53, &[5]), (54, &SERVER)]));
    assert_eq!((dhcp.state, dhcp.counters().missing), (DhcpState::Requesting, 4));
}

#[test]
fn options_that_overrun_or_have_the_wrong_length_are_malformed() {
    let mut dhcp = client(NET);
    dhcp.second();
    let xid = xid_of(&dhcp);
    let cases: Vec<Vec<u8>> = vec![
        // The lease's length says 4, two bytes follow.
        [&reply(xid, OFFERED, &[(53, &[2]), (54, &SERVER)])[..249], &[51, 4, 0, 0][..]].concat(),
        // A length byte missing at the very end.
        [&reply(xid, OFFERED, &[(53, &[2])])[..243], &[51][..]].concat(),
        // A length running past the end.
        reply(xid, OFFERED, &[(53, &[2]), (54, &SERVER), (51, &[0, 0, 0, 60]), (43, &[0; 10])])[..262].to_vec(),
        reply(xid, OFFERED, &[(53, &[2, 2]), (54, &SERVER), (51, &[0, 0, 0, 60])]),
        reply(xid, OFFERED, &[(53, &[2]), (54, &SERVER[..3]), (51, &[0, 0, 0, 60])]),
        reply(xid, OFFERED, &[(53, &[2]), (54, &SERVER), (51, &[0, 0, 60])]),
        reply(xid, OFFERED, &[(53, &[2]), (54, &SERVER), (51, &[0, 0, 0, 60]), (1, &[255, 255, 0])]),
        reply(xid, OFFERED, &[(53, &[2]), (54, &SERVER), (51, &[0, 0, 0, 60]), (3, &[10, 0, 0, 1, 10])]),
        reply(xid, OFFERED, &[(53, &[2]), (54, &SERVER), (51, &[0, 0, 0, 60]), (3, &[])]),
        reply(xid, OFFERED, &[(53, &[2]), (54, &SERVER), (51, &[0, 0, 0, 60]), (58, &[0, 0, 60])]),
    ];
    for (i, message) in cases.iter().enumerate() {
        assert!(!give(&mut dhcp, message), "case {i}");
        assert_eq!(dhcp.counters().malformed, i as u16 + 1, "case {i}");
    }
    assert_eq!(dhcp.state, DhcpState::Selecting);
}

#[test]
fn a_router_list_gives_its_first_and_pads_and_unknown_options_are_skipped() {
    let mut dhcp = client(NET);
    dhcp.second();
    let xid = xid_of(&dhcp);
    let mut offer = reply(xid, OFFERED, &[(43, &[1, 2, 3]), (53, &[2]), (54, &SERVER), (51, &[0, 0, 0, 60])]);
    // One pad before the first option and one between two (read as options, each would
    // take the next code for its length).
    offer.insert(240, 0);
    offer.insert(240 + 1 + 5, 0);
    offer.truncate(offer.len() - 1);
    offer.extend_from_slice(&[3, 8, 10, 0, 0, 5, 10, 0, 0, 6, 255]);
    assert!(give(&mut dhcp, &offer));
    assert_eq!(&dhcp.leased[GATEWAY..GATEWAY + 4], &[10, 0, 0, 5]);
}

#[test]
fn an_offer_without_an_end_option_is_read_to_the_datagrams_end() {
    let mut dhcp = client(NET);
    dhcp.second();
    let mut offer = offer(&dhcp, 60);
    offer.pop();
    assert!(give(&mut dhcp, &offer));
}

#[test]
fn messages_not_awaited_are_refused() {
    let mut dhcp = bound(100);
    let ack = ack(&dhcp, 100);
    let offer = reply(xid_of(&dhcp), OFFERED, &[(53, &[2]), (54, &SERVER), (51, &[0, 0, 0, 60])]);
    let request = reply(xid_of(&dhcp), OFFERED, &[(53, &[3])]);
    for m in [&ack, &offer, &request] {
        assert!(!give(&mut dhcp, m));
    }
    assert_eq!(dhcp.counters().unexpected, 3);
    assert_eq!(dhcp.status().remaining, 100);
}

/// The times (seconds from the start) at which messages go out while no server answers.
fn silence(dhcp: &mut Dhcp, seconds: u32) -> Vec<u32> {
    (1..=seconds).filter(|_| dhcp.second()).collect()
}

#[test]
fn a_silent_server_is_asked_again_after_4_8_16_32_then_every_64_s() {
    let mut dhcp = client(NET);
    assert_eq!(silence(&mut dhcp, 400), [1, 5, 13, 29, 61, 125, 189, 253, 317, 381]);
    assert_eq!(dhcp.counters().retries, 9);
    assert_eq!(xid_of(&dhcp), xid_of(&dhcp));
}

#[test]
fn a_request_unanswered_four_times_goes_back_to_discovery() {
    let mut dhcp = client(NET);
    dhcp.second();
    let offer = offer(&dhcp, 60);
    give(&mut dhcp, &offer);
    // The REQUEST sent at once (second 0 of requesting), then at 4, 12 and 28 s; at 60 s a
    // DISCOVER.
    let mut kinds = Vec::new();
    for t in 1..=61 {
        if dhcp.second() {
            kinds.push((t, option_of(&sent(&dhcp), 53).unwrap()[0]));
        }
    }
    assert_eq!(kinds, [(4, 3), (12, 3), (28, 3), (60, 1)]);
    assert_eq!(dhcp.state, DhcpState::Selecting);
}

#[test]
fn the_fallback_comes_after_its_seconds_and_gives_way_to_a_lease() {
    let mut dhcp = client(NET.fallback_after(10));
    for _ in 0..9 {
        dhcp.second();
    }
    assert_eq!(ip_now(&dhcp), [0; 4]);
    assert!(!dhcp.status().fallback);
    dhcp.second();
    assert_eq!(dhcp.addresses(), NET.addresses, "the Network's own addresses");
    assert!(dhcp.status().fallback);
    // Discovery goes on.
    assert!(!silence(&mut dhcp, 64).is_empty());
    let offer = offer(&dhcp, 30);
    give(&mut dhcp, &offer);
    assert_eq!(dhcp.addresses(), NET.addresses, "an offer is not a lease");
    let ack = ack(&dhcp, 30);
    give(&mut dhcp, &ack);
    assert_eq!(ip_now(&dhcp), OFFERED);
    assert!(!dhcp.status().fallback);
    // Lost: no address, then the fallback 10 s later.
    for _ in 0..30 {
        dhcp.second();
    }
    assert_eq!(ip_now(&dhcp), [0; 4]);
    for _ in 0..10 {
        dhcp.second();
    }
    assert_eq!(ip_now(&dhcp), NET.ip());
}

#[test]
fn without_a_fallback_there_is_no_address_for_ever_without_a_lease() {
    let mut dhcp = client(NET);
    silence(&mut dhcp, 100_000);
    assert_eq!(ip_now(&dhcp), [0; 4]);
    assert!(!dhcp.status().fallback);
}

/// Every truncation and every one-byte change of a good answer, in every state that awaits
/// one: no crash, every refusal counted once, and whatever is taken is the server's address.
#[test]
fn every_truncation_and_byte_change_is_refused_or_keeps_the_right_address() {
    let awaiting: Vec<(Dhcp, Vec<u8>)> = {
        let mut selecting = client(NET);
        selecting.second();
        let offer = offer(&selecting, 600);
        let mut requesting = selecting.clone();
        give(&mut requesting, &offer);
        let ack_r = ack(&requesting, 600);
        let nak_r = nak(&requesting);
        let mut renewing = bound(600);
        while !renewing.second() {}
        let ack_n = ack(&renewing, 600);
        vec![(selecting, offer), (requesting.clone(), ack_r), (requesting, nak_r), (renewing, ack_n)]
    };
    let mut taken = 0;
    for (dhcp, good) in &awaiting {
        let mut variants: Vec<Vec<u8>> = (0..good.len()).map(|n| good[..n].to_vec()).collect();
        for at in 0..good.len() {
            for value in [0x00, 0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x33, 0x35, 0xFE, 0xFF, good[at] ^ 0x80] {
                let mut m = good.clone();
                m[at] = value;
                variants.push(m);
            }
        }
        for m in &variants {
            let mut d = dhcp.clone();
            let (before, leases, naks) = (refusals(&d), d.counters().leases, d.counters().naks);
            give(&mut d, m);
            let refused = refusals(&d) - before;
            let accepted = u32::from(d.counters().leases - leases) + u32::from(d.counters().naks - naks);
            let offer_taken = dhcp.state == DhcpState::Selecting && d.state == DhcpState::Requesting;
            assert_eq!(refused + accepted + u32::from(offer_taken), 1, "one outcome for {m:?}");
            if refused == 1 {
                assert_eq!(d.addresses(), dhcp.addresses(), "a refusal changes nothing");
                assert_eq!(d.state, dhcp.state);
            }
            if d.holds() {
                assert_eq!(ip_now(&d), OFFERED);
                taken += 1;
            }
            if offer_taken {
                let yiaddr = [m[16], m[17], m[18], m[19]];
                assert!(usable(yiaddr));
                assert_eq!(ip_of(&d.leased), yiaddr);
            }
        }
    }
    assert!(taken > 0);
}

#[test]
fn random_datagrams_never_crash_nor_bind() {
    let mut dhcp = client(NET);
    dhcp.second();
    let xid = xid_of(&dhcp);
    let mut seed: u32 = 1;
    for n in 0..20_000 {
        let len = (n * 7) % 600;
        let mut m: Vec<u8> = (0..len)
            .map(|_| {
                seed = seed.wrapping_mul(1_103_515_245).wrapping_add(12_345);
                (seed >> 16) as u8
            })
            .collect();
        // Half of them look like this exchange's replies, so that the options are walked.
        if n % 2 == 0 && len >= 240 {
            m[..4].copy_from_slice(&[2, 1, 6, 0]);
            m[4..8].copy_from_slice(&xid);
            m[28..34].copy_from_slice(&MAC_ADDRESS);
            m[236..240].copy_from_slice(&COOKIE);
        }
        let mut d = dhcp.clone();
        let before = refusals(&d);
        give(&mut d, &m);
        assert!(refusals(&d) == before + 1 || d.state == DhcpState::Requesting);
        assert!(!d.holds());
    }
}

#[test]
fn a_lease_longer_than_the_longest_kept_is_renewed_within_that() {
    let mut dhcp = client(NET);
    dhcp.second();
    let offer = offer(&dhcp, 7 * 86_400);
    give(&mut dhcp, &offer);
    // A week, with T1 and T2 of three and six days: taken as 65534 s, renewed at half.
    let ack = reply(
        xid_of(&dhcp),
        OFFERED,
        &[
            (53, &[5]),
            (54, &SERVER),
            (51, &(7 * 86_400u32).to_be_bytes()),
            (58, &259_200u32.to_be_bytes()),
            (59, &518_400u32.to_be_bytes()),
        ],
    );
    give(&mut dhcp, &ack);
    assert_eq!(dhcp.status().remaining, u32::from(LONGEST));
    assert_eq!((dhcp.t1, dhcp.t2), (LONGEST / 2, LONGEST - LONGEST / 8));
    let first = (1..=u32::from(LONGEST)).find(|_| dhcp.second());
    assert_eq!(first, Some(u32::from(LONGEST / 2)));
    assert_eq!(dhcp.state, DhcpState::Renewing);
}

/// A chip with socket 3 for UDP: datagrams land behind the chips' 8-byte header; what the
/// client sends, the addresses it sets and the sockets it closes are recorded.
struct UdpChip {
    status: [u8; 4],
    rx: Vec<u8>,
    rx_rd: u16,
    tx: Vec<u8>,
    sent: Vec<([u8; 4], u16, Vec<u8>)>,
    addresses: Option<[u8; ADDRESSES]>,
    closed: Vec<u8>,
    opened: usize,
}

impl UdpChip {
    fn new() -> UdpChip {
        UdpChip {
            status: [super::super::wiznet::state::LISTEN; 4],
            rx: Vec::new(),
            rx_rd: 0,
            tx: vec![0; 0x10000],
            sent: Vec::new(),
            addresses: None,
            closed: Vec::new(),
            opened: 0,
        }
    }

    /// A datagram from `ip`:`port`, its header saying `len` bytes.
    fn land(&mut self, port: u16, len: u16, payload: &[u8]) {
        self.rx.extend_from_slice(&SERVER);
        self.rx.extend_from_slice(&port.to_be_bytes());
        self.rx.extend_from_slice(&len.to_be_bytes());
        self.rx.extend_from_slice(payload);
    }
}

impl Sockets for UdpChip {
    fn events(&mut self) -> u8 {
        0
    }
    fn take_events(&mut self, _: u8) -> u8 {
        0
    }
    fn status(&mut self, s: u8) -> u8 {
        self.status[usize::from(s)]
    }
    fn command(&mut self, s: u8, command: u8) {
        assert_eq!(command, super::super::wiznet::command::CLOSE);
        self.status[usize::from(s)] = 0;
        self.closed.push(s);
    }
    fn listen(&mut self, _: u8, _: u16) {
        unreachable!()
    }
    fn peer(&mut self, _: u8) -> [u8; 4] {
        unreachable!()
    }
    #[cfg(feature = "udp")]
    fn open(&mut self, _: u8, _: u16, _: bool) {
        unreachable!()
    }
    #[cfg(feature = "udp")]
    fn set_peer(&mut self, _: u8, _: &mut [u8]) {
        unreachable!()
    }
    fn received(&mut self, _: u8) -> u16 {
        (self.rx.len() - usize::from(self.rx_rd)) as u16
    }
    fn rx_pointer(&mut self, _: u8) -> u16 {
        self.rx_rd
    }
    fn read(&mut self, _: u8, pointer: u16, buf: &mut [u8]) {
        let at = usize::from(pointer);
        assert!(at + buf.len() <= self.rx.len(), "read past the received bytes");
        buf.copy_from_slice(&self.rx[at..at + buf.len()]);
    }
    fn take(&mut self, _: u8, _: u16) {
        unreachable!("UDP takes with take_now")
    }
    fn tx_free(&mut self, _: u8) -> u16 {
        2048
    }
    fn tx_pointer(&mut self, _: u8) -> u16 {
        0x100
    }
    fn write(&mut self, _: u8, pointer: u16, data: &mut [u8]) {
        let at = usize::from(pointer);
        self.tx[at..at + data.len()].copy_from_slice(data);
    }
    fn send(&mut self, _: u8, _: u16) {
        unreachable!("UDP sends with send_to")
    }
}

impl Udp for UdpChip {
    fn open_udp(&mut self, s: u8, port: u16) {
        assert_eq!((s, port), (3, CLIENT_PORT));
        self.status[3] = crate::tcp::wiznet::state::UDP;
        self.opened += 1;
    }
    fn send_to(&mut self, s: u8, ip: [u8; 4], port: u16, pointer: u16) {
        assert_eq!(s, 3);
        self.sent.push((ip, port, self.tx[0x100..usize::from(pointer)].to_vec()));
    }
    fn take_now(&mut self, _: u8, pointer: u16) {
        assert!(usize::from(pointer) <= self.rx.len());
        self.rx_rd = pointer;
    }
    fn set_addresses(&mut self, addresses: &mut [u8; ADDRESSES]) {
        self.addresses = Some(*addresses);
    }
}

#[test]
fn poll_opens_the_socket_sends_takes_datagrams_and_applies_the_lease() {
    let mut net = NET;
    let mut dhcp = client(net);
    let mut chip = UdpChip::new();
    chip.status[3] = 0;
    // Not yet open: opened, nothing read.
    assert!(poll(&mut dhcp, &mut chip, &mut net, false), "the Network's IP replaced by none");
    assert_eq!(chip.addresses.map(|a| ip_of(&a)), Some([0; 4]));
    assert_eq!(chip.opened, 1);
    assert!(!poll(&mut dhcp, &mut chip, &mut net, true));
    let (to, port, discover) = chip.sent.pop().unwrap();
    assert_eq!((to, port, discover.len()), ([255; 4], SERVER_PORT, 300));
    assert_eq!(discover, sent(&dhcp));
    // From another port; a header whose length runs past what came: both refused, every
    // byte taken.
    let offer = offer(&dhcp, 100);
    chip.land(68, offer.len() as u16, &offer);
    assert!(!poll(&mut dhcp, &mut chip, &mut net, false));
    assert_eq!((dhcp.counters().not_reply, usize::from(chip.rx_rd)), (1, chip.rx.len()));
    chip.land(SERVER_PORT, offer.len() as u16 + 1, &offer);
    poll(&mut dhcp, &mut chip, &mut net, false);
    assert_eq!((dhcp.counters().short, usize::from(chip.rx_rd)), (1, chip.rx.len()));
    assert!(chip.sent.is_empty());
    // The offer, then its ACK: the REQUEST goes out at once, the lease applied, the server's
    // connections closed (socket 1 is connected; 0 and 2 listen and stay).
    chip.land(SERVER_PORT, offer.len() as u16, &offer);
    chip.status[1] = super::super::wiznet::state::ESTABLISHED;
    assert!(!poll(&mut dhcp, &mut chip, &mut net, false));
    assert_eq!(option_of(&chip.sent.pop().unwrap().2, 53), Some(vec![3]));
    let first = ack(&dhcp, 100);
    chip.land(SERVER_PORT, first.len() as u16, &first);
    assert!(poll(&mut dhcp, &mut chip, &mut net, false));
    assert_eq!(ip_of(&chip.addresses.unwrap()), OFFERED);
    assert_eq!(ip_of(&net.addresses), OFFERED, "the role's network holds the lease");
    assert_eq!(chip.closed, [3, 1], "socket 3 closed before it was opened for UDP, then 1");
    // A renewal keeps the address: nothing written, nothing closed.
    chip.addresses = None;
    for _ in 0..50 {
        poll(&mut dhcp, &mut chip, &mut net, true);
    }
    let (to, _, _) = chip.sent.pop().unwrap();
    assert_eq!(to, SERVER);
    let renewal = ack(&dhcp, 100);
    chip.land(SERVER_PORT, renewal.len() as u16, &renewal);
    assert!(!poll(&mut dhcp, &mut chip, &mut net, false));
    assert_eq!((chip.addresses, chip.closed.len()), (None, 2));
    assert_eq!(dhcp.counters().leases, 2);
}
