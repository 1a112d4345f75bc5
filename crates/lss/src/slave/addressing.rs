//! How an LSS slave in waiting state is picked out by the master: switch mode selective (the
//! four parts of its address in order), identify remote slave (vendor and product equal,
//! revision and serial within ranges) and the Fastscan responder.
//!
//! Fastscan responder: a slave that is in waiting state (or in either state, with
//! [`fastscan_in_configuration`](super::SlaveConfig::fastscan_in_configuration), as real
//! slaves behave) and has neither an active nor a pending node-ID answers bit check 0x80 (and
//! resets its scan position to the vendor-ID); otherwise it answers when `LSSSub` is its scan
//! position and bits `BitChecked..=31` of its address part equal the IDNumber's, then moves its
//! scan position to `LSSNext`. A full match (`BitChecked` 0) whose `LSSNext` is lower than
//! `LSSSub` completes the address: the slave enters configuration state.

use super::{LssSlave, SlaveState};
use crate::address::AddressPart;
use crate::wire::{BIT_CHECK_CONFIRM, IdentifyField, Response};

impl LssSlave {
    pub(super) fn selective(&mut self, part: AddressPart, value: u32) {
        if self.state != SlaveState::Waiting {
            return;
        }
        let matched = value == self.config.address.get(part) && self.selective == part.index();
        self.selective = if matched { part.index() + 1 } else { 0 };
        if self.selective == 4 {
            self.selective = 0;
            self.enter(SlaveState::Configuration);
            self.answer(Response::SwitchModeSelective);
        }
    }

    pub(super) fn identify(&mut self, field: IdentifyField, value: u32) {
        let a = &self.config.address;
        let (step, ok) = match field {
            IdentifyField::Vendor => (0, value == a.vendor_id),
            IdentifyField::Product => (1, value == a.product_code),
            IdentifyField::RevisionLow => (2, a.revision_number >= value),
            IdentifyField::RevisionHigh => (3, a.revision_number <= value),
            IdentifyField::SerialLow => (4, a.serial_number >= value),
            IdentifyField::SerialHigh => (5, a.serial_number <= value),
        };
        // The vendor-ID always starts a new sequence.
        let continues = step == 0 || self.identify == step;
        self.identify = if ok && continues { step + 1 } else { 0 };
        if self.identify == 6 {
            self.identify = 0;
            self.answer(Response::IdentifySlave);
        }
    }

    pub(super) fn fastscan(&mut self, id_number: u32, bit_check: u8, lss_sub: u8, lss_next: u8) {
        let in_state = self.state == SlaveState::Waiting || self.config.fastscan_in_configuration;
        if !in_state || !self.is_unconfigured() {
            return;
        }
        let (Some(sub), Some(_)) = (
            AddressPart::from_index(lss_sub),
            AddressPart::from_index(lss_next),
        ) else {
            return;
        };
        if bit_check == BIT_CHECK_CONFIRM {
            self.fastscan_pos = 0;
            self.answer(Response::IdentifySlave);
            return;
        }
        if bit_check > 31 || lss_sub != self.fastscan_pos {
            return;
        }
        let mask = u32::MAX << bit_check;
        if (self.config.address.get(sub) ^ id_number) & mask != 0 {
            return;
        }
        self.answer(Response::IdentifySlave);
        self.fastscan_pos = lss_next;
        if bit_check == 0 && lss_next < lss_sub {
            self.fastscan_pos = 0;
            self.enter(SlaveState::Configuration);
        }
    }
}
