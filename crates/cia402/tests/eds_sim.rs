//! eds/cia402-servo.eds against the crate: every profile object of `objects::ALL` is in the
//! EDS with the same data type, the simulated drive answers every EDS object of the profile area
//! with the EDS default, and the default PDO mappings name mappable objects the simulator has.

use canola_cia402::objects;
use canola_cia402::sim::SimDrive;

fn eds() -> canola_od::model::ObjectDictionary {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../eds/cia402-servo.eds");
    let text = std::fs::read(path).expect("eds/cia402-servo.eds");
    canola_od::parse(&text).expect("parses").od
}

#[test]
fn every_profile_object_is_in_the_eds_with_its_type() {
    let od = eds();
    for o in objects::ALL {
        let sub = od
            .sub(o.index, o.sub_index)
            .unwrap_or_else(|| panic!("{:#06x}:{} {} missing", o.index, o.sub_index, o.name));
        assert_eq!(sub.data_type, o.data_type, "{}", o.name);
    }
}

#[test]
fn the_simulated_drive_starts_with_the_eds_defaults() {
    let od = eds();
    let sim = SimDrive::default();
    let mut checked = 0;
    for o in objects::ALL {
        let sub = od.sub(o.index, o.sub_index).unwrap();
        assert_eq!(
            sub.access.is_writable(),
            sim_writable(&sim, o.index, o.sub_index),
            "{}",
            o.name
        );
        if !sub.access.is_writable() && o.index != 0x6502 {
            // Values the drive computes (statusword, actual values): the EDS default is 0.
            continue;
        }
        let want = sub.effective_value(1).expect("default").to_le_bytes();
        let mut got = [0u8; 8];
        let n = sim.read(o.index, o.sub_index, &mut got).unwrap();
        assert_eq!(
            &got[..n],
            &want[..],
            "{:#06x}:{} {}",
            o.index,
            o.sub_index,
            o.name
        );
        checked += 1;
    }
    assert!(checked > 35, "{checked} defaults compared");
}

fn sim_writable(sim: &SimDrive, index: u16, sub: u8) -> bool {
    let mut probe = sim.clone();
    let mut buf = [0u8; 8];
    let n = probe.read(index, sub, &mut buf).unwrap();
    probe.write(index, sub, &buf[..n]).is_ok()
}

#[test]
fn default_pdo_mappings_name_mappable_objects_of_the_drive() {
    let od = eds();
    let sim = SimDrive::default();
    for (base, writable) in [(0x1600u16, true), (0x1A00, false)] {
        for n in 0..4 {
            let count = od
                .sub(base + n, 0)
                .unwrap()
                .effective_value(1)
                .unwrap()
                .to_le_bytes()[0];
            assert!(count >= 2);
            for k in 1..=count {
                let raw = od
                    .sub(base + n, k)
                    .unwrap()
                    .effective_value(1)
                    .unwrap()
                    .to_le_bytes();
                let entry = u32::from_le_bytes(raw[..4].try_into().unwrap());
                let (index, sub, bits) = ((entry >> 16) as u16, (entry >> 8) as u8, entry as u8);
                let target = od.sub(index, sub).unwrap();
                assert!(target.pdo_mapping, "{index:#06x} not mappable");
                assert_eq!(
                    target.data_type.size().map(|s| s * 8),
                    Some(usize::from(bits))
                );
                assert_eq!(target.access.is_writable(), writable, "{index:#06x}");
                let mut buf = [0u8; 8];
                assert!(sim.read(index, sub, &mut buf).is_ok());
            }
        }
    }
}
