//! Unit tests of the SocketCAN transport's pure parts: frame decoding and encoding, error
//! frames, timeout reuse, kernel timestamps.

use super::*;

fn raw(id: u32, len: u8, data: [u8; 8]) -> [u8; 16] {
    let mut b = [0u8; 16];
    b[..4].copy_from_slice(&id.to_ne_bytes());
    b[4] = len;
    b[8..].copy_from_slice(&data);
    b
}

#[test]
fn decodes_kernel_frames() {
    let f = decode_raw(&raw(0x605, 4, [0x40, 0x17, 0x10, 0, 0, 0, 0, 0])).unwrap();
    assert_eq!(
        f,
        RawFrame::Frame(
            CanFrame::new(CanId::standard(0x605).unwrap(), &[0x40, 0x17, 0x10, 0]).unwrap()
        )
    );
    let r = decode_raw(&raw(0x705 | CAN_RTR_FLAG, 1, [0; 8])).unwrap();
    assert_eq!(
        r,
        RawFrame::Frame(CanFrame::remote(CanId::standard(0x705).unwrap(), 1).unwrap())
    );
    let e = decode_raw(&raw(0x1234 | CAN_EFF_FLAG, 0, [0; 8])).unwrap();
    assert!(matches!(e, RawFrame::Frame(f) if f.id().is_extended()));
    assert_eq!(decode_raw(&raw(0x605, 9, [0; 8])), None);
    assert_eq!(decode_raw(&[0; 3]), None);
    let err = decode_raw(&raw(CAN_ERR_FLAG | CAN_ERR_BUSOFF, 8, [0; 8])).unwrap();
    assert_eq!(
        err,
        RawFrame::Error {
            class: CAN_ERR_BUSOFF,
            data: [0; 8]
        }
    );
}

#[test]
fn decodes_kernel_fd_frames() {
    let mut b = [0u8; CANFD_MTU];
    b[..4].copy_from_slice(&0x123u32.to_ne_bytes());
    b[4] = 12;
    b[5] = 0x05; // BRS | FDF
    for (i, x) in b[8..20].iter_mut().enumerate() {
        *x = i as u8;
    }
    let f = decode_raw_fd(&b).unwrap();
    assert_eq!(f.id(), CanId::standard(0x123).unwrap());
    assert_eq!(
        (f.flags().bits(), f.data().len(), f.data()[11]),
        (5, 12, 11)
    );
    // What is sent decodes to the same frame (FDF is the kernel's: not written).
    let sent = encode_raw_fd(&f);
    assert_eq!(sent[5], 0x01);
    assert_eq!(&sent[..5], &b[..5]);
    assert_eq!(decode_raw_fd(&sent), Some(f.with_flags(FdFlags::BRS)));
    // A length between the FD lengths is padded as the wire carries it.
    b[4] = 9;
    assert_eq!(decode_raw_fd(&b).unwrap().data().len(), 12);
    b[..4].copy_from_slice(&(0x1234_5678 | CAN_EFF_FLAG).to_ne_bytes());
    let ext = decode_raw_fd(&b).unwrap();
    assert!(ext.id().is_extended());
    assert_eq!(
        decode_raw_fd(&encode_raw_fd(&ext)),
        Some(ext.with_flags(FdFlags::BRS))
    );
    b[4] = 65;
    assert_eq!(decode_raw_fd(&b), None);
    b[4] = 8;
    b[..4].copy_from_slice(&(1 | CAN_ERR_FLAG).to_ne_bytes());
    assert_eq!(decode_raw_fd(&b), None);
    assert_eq!(decode_raw_fd(&b[..5]), None);
}

#[test]
fn receive_timeouts_are_reused_only_close_to_the_wait() {
    let ms = std::time::Duration::from_millis;
    let us = std::time::Duration::from_micros;
    // The master's drive slice: the next wait is a few microseconds shorter or longer.
    assert!(reuse_timeout(ms(2), ms(2) - us(7)));
    assert!(reuse_timeout(ms(2) - us(7), ms(2)));
    // Never more than 1/16 of the wait late.
    assert!(reuse_timeout(ms(2) + us(125), ms(2)));
    assert!(!reuse_timeout(ms(2) + us(126), ms(2)));
    assert!(!reuse_timeout(ms(50), ms(1)));
    // Early by at most half of the wait.
    assert!(reuse_timeout(ms(1), ms(2)));
    assert!(!reuse_timeout(ms(1), ms(2) + us(1)));
    assert!(!reuse_timeout(us(100), ms(50)));
}

#[test]
fn kernel_stamps_move_onto_the_monotonic_clock_in_order() {
    let s = std::time::Duration::from_micros;
    let at = Instant::from_micros;
    // Received 3 ms before the read: stamped 3 ms before the transport's reading.
    assert_eq!(
        kernel_stamp(s(10_000), s(13_000), at(50_000), at(0)),
        at(47_000)
    );
    // Never before the frame read before it (the real-time clock stepped back meanwhile).
    assert_eq!(
        kernel_stamp(s(10_000), s(13_000), at(50_000), at(48_000)),
        at(48_000)
    );
    // Never after the reading (a stamp from the future: the clock stepped forward).
    assert_eq!(
        kernel_stamp(s(20_000), s(13_000), at(50_000), at(0)),
        at(50_000)
    );
    // An age beyond the clock's epoch saturates.
    assert_eq!(kernel_stamp(s(0), s(90_000), at(50_000), at(0)), at(0));
}

#[test]
fn error_frames_become_state_events() {
    let ev = error_events(
        CAN_ERR_CRTL | CAN_ERR_BUSOFF,
        [0, CAN_ERR_CRTL_TX_PASSIVE, 0, 0, 0, 0, 0, 0],
    );
    assert!(ev.contains(&BusEvent::ErrorPassive));
    assert!(ev.contains(&BusEvent::BusOff));
    assert!(matches!(ev[0], BusEvent::ErrorFrame { .. }));
    assert_eq!(
        error_events(CAN_ERR_RESTARTED, [0; 8])[1],
        BusEvent::Restarted
    );
}
