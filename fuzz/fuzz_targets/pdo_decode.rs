//! PDO and MPDO decoding against random mappings and random frames: a mapping built from the
//! input's raw entries goes through `unpack`/`pack` and a receive PDO of the engine (with SYNC,
//! timeouts and a synchronous variant); the remaining bytes are frames of any length, also fed
//! to the MPDO decoder and consumer. Nothing may panic; unpack-then-pack keeps the mapped bits.
#![no_main]

use canola_frame::{CanFrame, CanId, Instant, NodeId};
use canola_pdo::{
    CommParams, DispatcherEntry, Engine, Mapping, MpdoConsumer, NullStore, PdoConfig, RawValue,
    TransmissionType, pack, unpack,
};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&count, rest)) = data.split_first() else {
        return;
    };
    // Up to 65 raw entries (one more than allowed), four bytes each.
    let n = (count as usize % 66).min(rest.len() / 4);
    let (entry_bytes, mut frames) = rest.split_at(n * 4);
    let entries: Vec<u32> = entry_bytes
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    let mapping = Mapping::from_raw(&entries).ok();

    let Ok(id) = CanId::standard(0x181) else {
        return;
    };
    let mut engine: Engine<2, 0> = Engine::new();
    if let Some(m) = &mapping {
        let _ = engine.add_rpdo(PdoConfig::new(
            CommParams::event_driven(0x181).with_event_timer(count as u16),
            m.clone(),
        ));
        let _ = engine.add_rpdo(PdoConfig::new(
            CommParams::event_driven(0x182).with_transmission_type(TransmissionType::SyncAcyclic),
            m.clone(),
        ));
    }
    let mut consumer: MpdoConsumer<2> = MpdoConsumer::new(NodeId::MIN);
    let _ = consumer.push(DispatcherEntry(
        u64::from(count) << 56 | 0x2000_0000_6000_0001,
    ));
    let mut store = NullStore;
    let mut t = 0u64;

    // Frames: one length byte (low nibble = length, bit 4 = RTR, bits 5..6 = which COB-ID),
    // then the data bytes.
    while let Some((&head, tail)) = frames.split_first() {
        let len = (head & 0x0F) as usize;
        let take = len.min(8).min(tail.len());
        let (payload, next) = tail.split_at(take);
        frames = next;
        t += u64::from(head);
        let now = Instant::from_micros(t * 1000);
        let cob = match (head >> 5) & 3 {
            0 => 0x181,
            1 => 0x182,
            2 => 0x080,
            _ => 0x185,
        };
        let fid = CanId::standard(cob).unwrap_or(id);
        let frame = if head & 0x10 != 0 {
            CanFrame::remote(fid, len.min(8))
        } else {
            CanFrame::new(fid, payload)
        };
        if let Ok(frame) = frame {
            engine.handle_frame(now, &frame, &mut store);
        }
        engine.handle_timeout(now, &mut store);
        while engine.poll_event().is_some() {}
        while engine.poll_transmit().is_some() {}
        let _ = engine.poll_timeout();

        if let Some(m) = &mapping
            && let Ok(u) = unpack(m, payload)
        {
            let values: Vec<RawValue> = u.iter().map(|(_, v)| v).collect();
            let mut out = [0u8; 8];
            let packed = pack(m, &values, &mut out);
            assert!(
                packed.is_ok(),
                "unpacked values must pack again: {packed:?}"
            );
            let mask = if m.bit_len() >= 64 {
                u64::MAX
            } else {
                (1u64 << m.bit_len()) - 1
            };
            assert_eq!(u64::from_le_bytes(out), u.word() & mask);
        }
        let _ = consumer.handle_data(payload, &mut store);
    }
});
