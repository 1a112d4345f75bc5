//! The line codec against byte strings: what python-can's slcan interface sends and parses
//! (`can/interfaces/slcan.py`), what the Linux kernel's slcan driver emits and accepts
//! (`drivers/net/can/slcan/slcan-core.c`), and the replies of Lawicel-style firmware, CANable's
//! firmware and can-utils' slcanpty, as collected in the project's slcan spec notes.

use canola_frame::{CanFrame, CanId, FdFrame};
use canola_slcan::{
    BitrateTable, Btr, BusErrors, BusState, Command, DataBitrate, Decoder, ErrorState, Frame, Item,
    LineError, MAX_COMMAND, NominalBitrate, RxFrame, StatusFlags, Timestamp, TimestampMode,
};
use proptest::prelude::*;

fn sid(raw: u16) -> CanId {
    CanId::standard(raw).unwrap()
}

fn eid(raw: u32) -> CanId {
    CanId::extended(raw).unwrap()
}

fn encode(cmd: Command) -> Vec<u8> {
    let mut buf = [0u8; MAX_COMMAND];
    let n = cmd.encode(&mut buf).unwrap();
    buf[..n].to_vec()
}

/// Every item of `bytes` fed in one chunk.
fn decode_all(bytes: &[u8]) -> Vec<Result<Item, LineError>> {
    Decoder::new().feed(bytes).collect()
}

fn frame_item(frame: impl Into<Frame>) -> Result<Item, LineError> {
    Ok(Item::Frame(RxFrame::new(frame.into())))
}

#[test]
fn control_commands_as_python_can_and_the_kernel_send_them() {
    assert_eq!(encode(Command::Open), b"O\r");
    assert_eq!(encode(Command::ListenOnly), b"L\r");
    assert_eq!(encode(Command::Close), b"C\r");
    assert_eq!(encode(Command::Version), b"V\r");
    assert_eq!(encode(Command::Serial), b"N\r");
    assert_eq!(encode(Command::Status), b"F\r");
    // The kernel maps `bitrate 500000` to S6 and `800000` to S7.
    let s6 = NominalBitrate::from_bps(500_000, BitrateTable::Lawicel).unwrap();
    assert_eq!(encode(Command::Bitrate(s6)), b"S6\r");
    let s7 = NominalBitrate::from_bps(800_000, BitrateTable::Lawicel).unwrap();
    assert_eq!(encode(Command::Bitrate(s7)), b"S7\r");
    // python-can: 750000 -> "S7", 83300 -> "S9", 2000000 -> "Y2".
    let s7c = NominalBitrate::from_bps(750_000, BitrateTable::Canable).unwrap();
    assert_eq!(encode(Command::Bitrate(s7c)), b"S7\r");
    let s9 = NominalBitrate::from_bps(83_300, BitrateTable::Canable).unwrap();
    assert_eq!(encode(Command::Bitrate(s9)), b"S9\r");
    let y2 = DataBitrate::from_bps(2_000_000).unwrap();
    assert_eq!(encode(Command::DataBitrate(y2)), b"Y2\r");
    // python-can and `slcand -b`: `s%02X%02X` of BTR0/BTR1 (here 500 kbit/s on 8 MHz).
    let btr = Btr {
        btr0: 0x00,
        btr1: 0x1C,
    };
    assert_eq!(encode(Command::Btr(btr)), b"s001C\r");
    assert_eq!(encode(Command::Timestamps(TimestampMode::Millis)), b"Z1\r");
}

#[test]
fn frames_as_python_can_and_the_kernel_send_them() {
    // Kernel header comment examples, upper-case hex as `hex_asc_upper` writes them.
    let cases: [(Frame, &[u8]); 7] = [
        (CanFrame::new(sid(0x123), &[]).unwrap().into(), b"t1230\r"),
        (
            CanFrame::new(sid(0x456), &[0x11, 0x22, 0x33])
                .unwrap()
                .into(),
            b"t4563112233\r",
        ),
        (
            CanFrame::new(eid(0x12AB_CDEF), &[0xAA, 0x55])
                .unwrap()
                .into(),
            b"T12ABCDEF2AA55\r",
        ),
        (CanFrame::remote(sid(0x123), 0).unwrap().into(), b"r1230\r"),
        // python-can: f"R{id:08X}{dlc:d}" with no data even when the DLC is above zero.
        (
            CanFrame::remote(eid(0x1234), 4).unwrap().into(),
            b"R000012344\r",
        ),
        // python-can: f"d{id:03X}{len2dlc(12):X}" + data.hex().upper().
        (
            FdFrame::new(
                sid(0x200),
                &[
                    0, 0x11, 0x22, 0x33, 0x44, 0x55, 0x66, 0x77, 0x88, 0x99, 0xAA, 0xBB,
                ],
            )
            .unwrap()
            .into(),
            b"d200900112233445566778899AABB\r",
        ),
        (
            FdFrame::new(eid(0x1FFF_FFFF), &[0xEE; 64])
                .unwrap()
                .with_brs(true)
                .into(),
            &[b"B1FFFFFFFF".as_slice(), &[b'E'; 128], b"\r"]
                .concat()
                .leak()[..],
        ),
    ];
    for (frame, line) in cases {
        assert_eq!(encode(Command::Transmit(frame)), line, "{frame:?}");
        // The same line parses back, as an adapter (and the Rx side) reads it.
        assert_eq!(
            Command::parse(&line[..line.len() - 1]),
            Ok(Command::Transmit(frame))
        );
        assert_eq!(decode_all(line), vec![frame_item(frame)]);
    }
}

#[test]
fn received_frames_in_either_case_with_timestamps_and_esi() {
    // The kernel and python-can accept lower-case hex.
    assert_eq!(
        decode_all(b"t4563aabbcc\r"),
        vec![frame_item(
            CanFrame::new(sid(0x456), &[0xAA, 0xBB, 0xCC]).unwrap()
        )]
    );
    // Z1: four hex digits of milliseconds after the data; EA5F is the largest (slcanpty,
    // EasySYNC, the kernel's SLCAN_MTU example line).
    let f = CanFrame::new(
        eid(0x1111_2222),
        &[0x11, 0x22, 0x33, 0x44, 0x55, 0x66, 0x77, 0x88],
    )
    .unwrap();
    assert_eq!(
        decode_all(b"T1111222281122334455667788EA5F\r"),
        vec![Ok(Item::Frame(RxFrame {
            frame: f.into(),
            timestamp: Some(Timestamp::Millis(59_999)),
            esi: None,
        }))]
    );
    // Nakakiyo's example: t100 2 0011 000A 0 = timestamp 10 ms, ESI 0.
    assert_eq!(
        decode_all(b"t10020011000A0\r"),
        vec![Ok(Item::Frame(RxFrame {
            frame: CanFrame::new(sid(0x100), &[0x00, 0x11]).unwrap().into(),
            timestamp: Some(Timestamp::Millis(10)),
            esi: Some(false),
        }))]
    );
    // Z2: eight hex digits of microseconds.
    assert_eq!(
        decode_all(b"r7FF8D693A3FF\r"),
        vec![Ok(Item::Frame(RxFrame {
            frame: CanFrame::remote(sid(0x7FF), 8).unwrap().into(),
            timestamp: Some(Timestamp::Micros(0xD693_A3FF)),
            esi: None,
        }))]
    );
}

#[test]
fn bad_frame_lines_are_typed_errors() {
    let cases: [(&[u8], LineError); 10] = [
        (b"t800", LineError::IdOutOfRange(0x800)),
        (b"T200000000", LineError::IdOutOfRange(0x2000_0000)),
        // Classic DLC is '0'..'8' only (kernel, CANable, slcanpty).
        (b"t1239", LineError::BadDlc(b'9')),
        (b"d12", LineError::Truncated),
        (b"t12", LineError::Truncated),
        (b"t1232AA", LineError::Truncated),
        (b"t12G0", LineError::BadHex(b'G')),
        (b"t1231GG", LineError::BadHex(b'G')),
        // Three trailing characters are neither timestamp nor ESI.
        (b"t1230ABC", LineError::BadTrailer(3)),
        (b"t123000002", LineError::BadTrailer(5)),
    ];
    for (line, err) in cases {
        assert_eq!(
            Item::parse(line),
            Err(err),
            "{:?}",
            String::from_utf8_lossy(line)
        );
    }
}

#[test]
fn replies_of_lawicel_firmware_and_slcanpty() {
    // slcanpty: V -> "V1013\r", N -> "N4242\r", F -> "F00\r"; BEL for errors, CR for OK.
    let items = decode_all(b"\rV1013\rN4242\rF00\r\x07z\rZ\r");
    assert_eq!(items.len(), 7);
    assert_eq!(items[0], Ok(Item::Ok));
    assert_eq!(items[1].as_ref().unwrap().lawicel_version(), Some((10, 13)));
    match &items[2] {
        Ok(Item::Serial(t)) => assert_eq!(t.as_str(), "4242"),
        other => panic!("{other:?}"),
    }
    assert_eq!(items[3], Ok(Item::Status(StatusFlags(0))));
    assert_eq!(items[4], Ok(Item::Error));
    assert_eq!(items[5], Ok(Item::TxAck { extended: false }));
    assert_eq!(items[6], Ok(Item::TxAck { extended: true }));
    // Nakakiyo's example: FA4 = bus error + error passive + warning.
    let Ok(Item::Status(flags)) = Item::parse(b"FA4") else {
        panic!()
    };
    assert!(flags.contains(
        StatusFlags::BUS_ERROR | StatusFlags::ERROR_PASSIVE | StatusFlags::ERROR_WARNING
    ));
    assert_eq!(Item::parse(b"F0"), Err(LineError::Malformed(b'F')));
}

#[test]
fn canable_free_text_version_is_not_an_error() {
    // CANable's official firmware answers V with "<git version> <git remote>\r".
    let items = decode_all(b"b6fe3a1 git@github.com:normaldotcom/canable2-fw.git\r");
    match &items[..] {
        [Ok(Item::Other(t))] => assert!(t.as_str().starts_with("b6fe3a1 ")),
        // 'b' starts a CAN FD frame line: must not be taken for one that fails.
        other => panic!("{other:?}"),
    }
}

#[test]
fn kernel_state_and_error_lines() {
    assert_eq!(
        Item::parse(b"sa057033"),
        Ok(Item::BusState(BusState {
            state: ErrorState::Active,
            rx_errors: 57,
            tx_errors: 33,
        }))
    );
    assert_eq!(
        Item::parse(b"sb256256"),
        Ok(Item::BusState(BusState {
            state: ErrorState::BusOff,
            rx_errors: 256,
            tx_errors: 256,
        }))
    );
    assert_eq!(
        Item::parse(b"e3bcO"),
        Ok(Item::BusErrors(BusErrors(
            BusErrors::BIT0 | BusErrors::CRC | BusErrors::TX_OVERRUN
        )))
    );
    assert_eq!(Item::parse(b"sa05703"), Err(LineError::Malformed(b's')));
    assert_eq!(Item::parse(b"e2a"), Err(LineError::Malformed(b'e')));
    assert_eq!(Item::parse(b"e1x"), Err(LineError::Malformed(b'e')));
}

#[test]
fn bel_ends_a_line_and_is_an_error() {
    // A BEL carries no CR: it ends the line before it (as the kernel's parser does) and is an
    // error reply of its own.
    assert_eq!(
        decode_all(b"t1230\x07\x07t1231AA\r"),
        vec![
            frame_item(CanFrame::new(sid(0x123), &[]).unwrap()),
            Ok(Item::Error),
            Ok(Item::Error),
            frame_item(CanFrame::new(sid(0x123), &[0xAA]).unwrap()),
        ]
    );
}

#[test]
fn bad_bytes_are_counted_and_the_decoder_resynchronises_at_cr() {
    let mut d = Decoder::new();
    let items: Vec<_> = d.feed(b"t12\xff30\rt1230\r\nt1231AA\r").collect();
    assert_eq!(
        items,
        vec![
            Err(LineError::BadByte(0xFF)),
            frame_item(CanFrame::new(sid(0x123), &[]).unwrap()),
            // LF is not part of the protocol: the line it starts is skipped.
            Err(LineError::BadByte(b'\n')),
        ]
    );
    assert_eq!(d.errors(), 2);
    assert_eq!(d.items(), 1);
    // An overlong line is one error, and the next line decodes.
    let long = [b"t".as_slice(), &[b'1'; 500], b"\rt1230\r"].concat();
    let items: Vec<_> = d.feed(&long).collect();
    assert_eq!(
        items,
        vec![
            Err(LineError::TooLong),
            frame_item(CanFrame::new(sid(0x123), &[]).unwrap()),
        ]
    );
    assert_eq!(d.errors(), 3);
}

#[test]
fn lines_split_across_chunks() {
    let stream = b"t4563112233\rT12ABCDEF2AA55\r\x07\r";
    let whole = decode_all(stream);
    for cut in 0..stream.len() {
        let mut d = Decoder::new();
        let mut items: Vec<_> = d.feed(&stream[..cut]).collect();
        items.extend(d.feed(&stream[cut..]));
        assert_eq!(items, whole, "cut at {cut}");
    }
}

#[test]
fn command_parse_rejects_what_an_adapter_would_bel() {
    let cases: [(&[u8], LineError); 8] = [
        (b"", LineError::Empty),
        (b"Q1", LineError::UnknownCommand(b'Q')),
        (b"S", LineError::Truncated),
        (b"SA", LineError::BadArgument(b'A')),
        (b"S66", LineError::TrailingCharacters),
        (b"Z3", LineError::BadArgument(b'3')),
        (b"s01", LineError::Truncated),
        (b"O1", LineError::TrailingCharacters),
    ];
    for (line, err) in cases {
        assert_eq!(
            Command::parse(line),
            Err(err),
            "{:?}",
            String::from_utf8_lossy(line)
        );
    }
    assert_eq!(
        Command::parse(b"s031C"),
        Ok(Command::Btr(Btr {
            btr0: 0x03,
            btr1: 0x1C
        }))
    );
}

#[test]
fn encode_reports_a_short_buffer() {
    let mut small = [0u8; 4];
    let f = CanFrame::new(sid(1), &[1, 2]).unwrap();
    assert_eq!(
        Command::Transmit(f.into()).encode(&mut small),
        Err(canola_slcan::EncodeError::BufferTooSmall { needed: 10 })
    );
}

fn any_id() -> impl Strategy<Value = CanId> {
    prop_oneof![
        (0u16..=0x7FF).prop_map(sid),
        (0u32..=0x1FFF_FFFF).prop_map(eid),
    ]
}

fn any_frame() -> impl Strategy<Value = Frame> {
    let fd_lens = prop::sample::select(vec![0usize, 1, 5, 8, 12, 16, 20, 24, 32, 48, 64]);
    prop_oneof![
        (any_id(), prop::collection::vec(any::<u8>(), 0..=8))
            .prop_map(|(id, d)| Frame::Classic(CanFrame::new(id, &d).unwrap())),
        (any_id(), 0usize..=8).prop_map(|(id, n)| Frame::Classic(CanFrame::remote(id, n).unwrap())),
        (any_id(), any::<bool>(), fd_lens, any::<[u8; 64]>()).prop_map(
            |(id, brs, n, d)| Frame::Fd(FdFrame::new(id, &d[..n]).unwrap().with_brs(brs))
        ),
    ]
}

fn any_rx() -> impl Strategy<Value = RxFrame> {
    let stamp = prop_oneof![
        Just(None),
        any::<u16>().prop_map(|v| Some(Timestamp::Millis(v))),
        any::<u32>().prop_map(|v| Some(Timestamp::Micros(v))),
    ];
    (any_frame(), stamp, prop::option::of(any::<bool>())).prop_map(|(frame, timestamp, esi)| {
        RxFrame {
            frame,
            timestamp,
            esi,
        }
    })
}

fn any_command() -> impl Strategy<Value = Command> {
    prop_oneof![
        Just(Command::Open),
        Just(Command::ListenOnly),
        Just(Command::Close),
        Just(Command::Version),
        Just(Command::Serial),
        Just(Command::Status),
        (0u8..=9).prop_map(|n| Command::Bitrate(NominalBitrate::from_code(n).unwrap())),
        (0u8..=9).prop_map(|n| Command::DataBitrate(DataBitrate::from_code(n).unwrap())),
        prop::sample::select(vec![
            TimestampMode::Off,
            TimestampMode::Millis,
            TimestampMode::Micros
        ])
        .prop_map(Command::Timestamps),
        any::<(u8, u8)>().prop_map(|(btr0, btr1)| Command::Btr(Btr { btr0, btr1 })),
        any_frame().prop_map(Command::Transmit),
    ]
}

proptest! {
    #[test]
    fn command_round_trip(cmd in any_command()) {
        let line = encode(cmd);
        prop_assert!(line.len() <= MAX_COMMAND);
        prop_assert_eq!(line.len(), cmd.encoded_len());
        prop_assert_eq!(line.last(), Some(&b'\r'));
        prop_assert_eq!(Command::parse(&line[..line.len() - 1]), Ok(cmd));
    }

    #[test]
    fn received_frames_round_trip_in_any_chunking(
        rxs in prop::collection::vec(any_rx(), 1..8),
        cuts in prop::collection::vec(any::<prop::sample::Index>(), 0..6),
    ) {
        let mut stream = Vec::new();
        for rx in &rxs {
            let mut buf = [0u8; canola_slcan::MAX_LINE + 1];
            let n = rx.encode(&mut buf).unwrap();
            stream.extend_from_slice(&buf[..n]);
        }
        let mut cuts: Vec<usize> = cuts.iter().map(|i| i.index(stream.len() + 1)).collect();
        cuts.push(stream.len());
        cuts.sort_unstable();
        let mut d = Decoder::new();
        let mut got = Vec::new();
        let mut at = 0;
        for cut in cuts {
            got.extend(d.feed(&stream[at..cut]));
            at = cut;
        }
        let want: Vec<_> = rxs.iter().map(|rx| Ok(Item::Frame(*rx))).collect();
        prop_assert_eq!(got, want);
        prop_assert_eq!(d.errors(), 0);
    }

    #[test]
    fn any_bytes_never_panic_and_resynchronise(noise in prop::collection::vec(any::<u8>(), 0..400)) {
        let mut d = Decoder::new();
        let n = d.feed(&noise).count() as u64;
        prop_assert_eq!(n, d.items() + d.errors());
        let _ = Command::parse(&noise);
        let _ = Item::parse(&noise);
        // After a CR, a good line decodes whatever came before it.
        let got: Vec<_> = d.feed(b"\rt1230\r").collect();
        prop_assert_eq!(got.last(), Some(&frame_item(CanFrame::new(sid(0x123), &[]).unwrap())));
    }

    #[test]
    fn printable_noise_lines_are_items_or_typed_errors(line in "[ -~]{0,170}") {
        let got = decode_all(&[line.as_bytes(), b"\r"].concat());
        prop_assert_eq!(got.len(), 1);
    }
}
