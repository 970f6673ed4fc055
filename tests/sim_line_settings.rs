//! Character formats and rates, Modbus over Serial Line v1.02 §2.5.1: the release
//! `dip_switch` firmware, its switches (pins 10, 11, 12) set before reset, configures
//! USART0 for the preset they select and answers FC 03 at that rate and format.

mod sim;

use sim::{with_crc, Rtu, ID};

/// USART0 runs the preset's rate (within 2.5 %, the firmware's limit), 8 data bits, its
/// parity and its stop bits, with receiver and transmitter on.
fn usart_matches_preset(preset: usize) {
    let rtu = Rtu::boot_dip(preset);
    let line = rtu.line;
    let cfg = rtu.uno.serial_config().expect("USART0 enabled");
    assert!(cfg.rx_enabled && cfg.tx_enabled, "{cfg:?}");
    assert_eq!((cfg.data_bits, cfg.parity, cfg.stop_bits), (8, line.parity, line.stop_bits), "{cfg:?}");
    assert!(
        cfg.baud_error(line.baud).abs() <= 0.025,
        "{} bps is {:+.2} % off {}",
        cfg.baud(),
        100.0 * cfg.baud_error(line.baud),
        line.name()
    );
    assert_eq!(u64::from(cfg.char_bits()), line.char_bits(), "{cfg:?}");
}

/// A write of 40002 with FC 06, then FC 03 over 40001–40003, at the preset's settings.
fn fc3_answers_at_preset(preset: usize) {
    let mut rtu = Rtu::boot_dip(preset);
    let write = with_crc(&[
        ID,   // slave address
        0x06, // function: write single register
        0x00, // register address hi
        0x01, // register address lo: 40002
        0xBE, // value hi
        0xEF, // value lo
    ]);
    assert_eq!(rtu.ask(&write), write, "{}: FC 06 echo", rtu.line.name());
    let read = with_crc(&[
        ID,   // slave address
        0x03, // function: read holding registers
        0x00, // starting address hi
        0x00, // starting address lo: 40001
        0x00, // quantity hi
        0x03, // quantity lo: 3
    ]);
    let reply = with_crc(&[
        ID,   // slave address
        0x03, // function
        0x06, // byte count
        0x00, 0x00, // 40001
        0xBE, 0xEF, // 40002
        0x00, 0x00, // 40003
    ]);
    let exchange = rtu.exchange(&read);
    assert_eq!(exchange.bytes(), reply, "{}: FC 03", rtu.line.name());
    // Characters of one frame follow each other within T1.5.
    assert!(
        exchange.max_reply_gap() <= rtu.line.t15(),
        "{}: gap of {} cycles inside the reply",
        rtu.line.name(),
        exchange.max_reply_gap()
    );
}

/// 30001 holds the preset number and 10001–10003 the switches as read at start-up.
fn reports_preset_and_switches(preset: usize) {
    let mut rtu = Rtu::boot_dip(preset);
    let read_preset = with_crc(&[
        ID,   // slave address
        0x04, // function: read input registers
        0x00, // starting address hi
        0x00, // starting address lo: 30001
        0x00, // quantity hi
        0x01, // quantity lo: 1
    ]);
    assert_eq!(rtu.ask(&read_preset), with_crc(&[ID, 0x04, 0x02, 0x00, preset as u8]), "30001");
    let read_switches = with_crc(&[
        ID,   // slave address
        0x02, // function: read discrete inputs
        0x00, // starting address hi
        0x00, // starting address lo: 10001
        0x00, // quantity hi
        0x03, // quantity lo: 3
    ]);
    assert_eq!(rtu.ask(&read_switches), with_crc(&[ID, 0x02, 0x01, preset as u8]), "10003..10001");
}

macro_rules! preset {
    ($module:ident, $preset:expr) => {
        mod $module {
            #[test]
            fn usart_is_configured_for_the_preset() {
                super::usart_matches_preset($preset);
            }

            #[test]
            fn fc3_is_answered_byte_for_byte() {
                super::fc3_answers_at_preset($preset);
            }

            #[test]
            fn preset_number_and_switches_read_back() {
                super::reports_preset_and_switches($preset);
            }
        }
    };
}

preset!(preset_0_19200_8e1, 0);
preset!(preset_1_9600_8e1, 1);
preset!(preset_2_19200_8n2, 2);
preset!(preset_3_19200_8o1, 3);
preset!(preset_4_115200_8n1, 4);
preset!(preset_5_9600_8n1, 5);
preset!(preset_6_115200_8e1, 6);
preset!(preset_7_1200_8e1, 7);
