//! The COB-ID entries of the communication profile that must not carry a CAN identifier
//! CiA 301 restricts (§7.3.5, [`canola_frame::cob::RESTRICTED`]): the PDOs' COB-IDs
//! (0x1400..=0x15FF and 0x1800..=0x19FF, sub-index 1), SYNC (0x1005), TIME (0x1012) and EMCY
//! (0x1014). A PDO or EMCY marked not valid (bit 31) and a 29-bit identifier (bit 29) are not
//! checked: a PDO is switched off by writing its COB-ID with bit 31 set, whatever the
//! identifier. The SDO channels (0x1200..) are left out: their default identifiers are the
//! restricted ones. The simulated device refuses such a write (abort 0x06090030), and the
//! master refuses to configure one (PDO remapping, boot from a DCF, audit repairs) or to
//! transmit a node's RPDO on one.

/// The restricted CAN identifier that writing `value` to `index:sub_index` would configure,
/// or `None` when the entry is not a COB-ID entry checked here or the value is allowed.
pub fn restricted_cob_id(index: u16, sub_index: u8, value: u32) -> Option<u16> {
    // Whether bit 31 marks the object not valid.
    let valid_bit = match (index, sub_index) {
        (0x1400..=0x15FF | 0x1800..=0x19FF, 1) => true,
        (0x1014, 0) => true,
        (0x1005 | 0x1012, 0) => false,
        _ => return None,
    };
    let disabled = valid_bit && value & 0x8000_0000 != 0;
    let extended = value & 0x2000_0000 != 0;
    let id = (value & 0x7FF) as u16;
    (!disabled && !extended && canola_frame::is_restricted(id)).then_some(id)
}

#[cfg(test)]
mod tests {
    use super::restricted_cob_id;

    #[test]
    fn the_restricted_ids_of_the_cob_id_entries() {
        // TPDO1 on the NMT identifier, RPDO on a default SDO response identifier.
        assert_eq!(restricted_cob_id(0x1800, 1, 0x0000_0000), Some(0x000));
        assert_eq!(restricted_cob_id(0x1400, 1, 0x0000_0585), Some(0x585));
        assert_eq!(restricted_cob_id(0x1014, 0, 0x0000_0701), Some(0x701));
        assert_eq!(restricted_cob_id(0x1005, 0, 0x4000_0005), Some(0x005));
        // Allowed: the predefined identifiers, a PDO switched off, 29-bit identifiers,
        // entries that are no COB-IDs, the SDO channels.
        assert_eq!(restricted_cob_id(0x1800, 1, 0x0000_0185), None);
        assert_eq!(restricted_cob_id(0x1800, 1, 0x8000_0000), None);
        assert_eq!(restricted_cob_id(0x1800, 1, 0x2000_0001), None);
        assert_eq!(restricted_cob_id(0x1005, 0, 0x0000_0080), None);
        assert_eq!(restricted_cob_id(0x1012, 0, 0x0000_0100), None);
        assert_eq!(restricted_cob_id(0x1800, 2, 0x0000_0001), None);
        assert_eq!(restricted_cob_id(0x1200, 1, 0x0000_0605), None);
        // SYNC has no valid bit: bit 31 does not switch the check off.
        assert_eq!(restricted_cob_id(0x1005, 0, 0x8000_0001), Some(0x001));
    }
}
