//! The simulated drive's homing (mode hm, CiA 402-2 §9): the search, creep and index phases of
//! methods 1..6, 17..22, 33, 34, 35, 37 against the home switch, the limit switches and the
//! index pulses, and the home offset applied where the reference is found.

use crate::mode::HomingStatus;
use crate::objects as obj;

use super::SimDrive;

/// Where a homing run is.
#[derive(Clone, Copy, PartialEq, Debug)]
pub(super) enum HomingPhase {
    /// Search the switch at the fast speed in a direction (+1/−1) until the switch reads `until`.
    Search {
        dir: f64,
        until: bool,
        switch: Switch,
    },
    /// Creep at the slow speed until the switch reads `until`; then index or done.
    Creep {
        dir: f64,
        until: bool,
        switch: Switch,
        index: bool,
    },
    /// Creep to the next index pulse.
    Index { dir: f64 },
}

/// A switch input of the drive.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(super) enum Switch {
    NegativeLimit,
    PositiveLimit,
    Home,
}

impl SimDrive {
    pub(super) fn switch(&self, s: Switch, at: f64) -> bool {
        let at = at - self.frame;
        match s {
            Switch::NegativeLimit => self.config.negative_limit_switch.is_some_and(|l| at <= l),
            Switch::PositiveLimit => self.config.positive_limit_switch.is_some_and(|l| at >= l),
            Switch::Home => at >= self.config.home_switch,
        }
    }

    pub(super) fn start_homing(&mut self) {
        let method = self.get(obj::HOMING_METHOD) as i8;
        let home = self.switch(Switch::Home, self.position);
        use HomingPhase::*;
        let phase = match method {
            35 | 37 => {
                self.homed_at(self.position);
                return;
            }
            1 => Search {
                dir: -1.0,
                until: true,
                switch: Switch::NegativeLimit,
            },
            2 => Search {
                dir: 1.0,
                until: true,
                switch: Switch::PositiveLimit,
            },
            17 => Search {
                dir: -1.0,
                until: true,
                switch: Switch::NegativeLimit,
            },
            18 => Search {
                dir: 1.0,
                until: true,
                switch: Switch::PositiveLimit,
            },
            // Home switch methods: approach the switch edge; the edge is then found at the slow
            // speed from the side the method names (3, 4, 19, 20 positive switch; 5, 6, 21, 22
            // negative side, modelled on the same switch).
            3 | 4 | 19 | 20 if !home => Search {
                dir: 1.0,
                until: true,
                switch: Switch::Home,
            },
            3 | 4 | 19 | 20 => Creep {
                dir: -1.0,
                until: false,
                switch: Switch::Home,
                index: method < 17,
            },
            5 | 6 | 21 | 22 if home => Search {
                dir: -1.0,
                until: false,
                switch: Switch::Home,
            },
            5 | 6 | 21 | 22 => Creep {
                dir: 1.0,
                until: true,
                switch: Switch::Home,
                index: method < 17,
            },
            33 => Index { dir: -1.0 },
            34 => Index { dir: 1.0 },
            _ => {
                self.homing = None;
                self.homing_status = HomingStatus::ErrorStandstill;
                return;
            }
        };
        self.homing = Some(phase);
        self.homing_status = HomingStatus::InProgress;
    }

    pub(super) fn homed_at(&mut self, edge: f64) {
        // The found reference becomes the home offset; the overshoot past it is kept.
        let offset = self.get(obj::HOME_OFFSET) as f64;
        let shift = offset - edge;
        self.position += shift;
        self.frame += shift;
        self.demand_position = self.position;
        self.pp_target = self.position;
        self.velocity = 0.0;
        self.demand_velocity = 0.0;
        self.homing = None;
        self.homing_status = HomingStatus::Completed;
    }

    pub(super) fn homing_step(&mut self, before: f64) {
        let Some(phase) = self.homing else { return };
        let method = self.get(obj::HOMING_METHOD) as i8;
        let p = self.position;
        let uses = |s: Switch| match s {
            Switch::NegativeLimit => matches!(method, 1 | 17),
            Switch::PositiveLimit => matches!(method, 2 | 18),
            Switch::Home => false,
        };
        for s in [Switch::NegativeLimit, Switch::PositiveLimit] {
            if self.switch(s, p) && !uses(s) {
                // A limit switch on the way: homing error, the drive stops.
                self.homing = None;
                self.homing_status = HomingStatus::ErrorMoving;
                return;
            }
        }
        use HomingPhase::*;
        match phase {
            Search { dir, until, switch } => {
                if self.switch(switch, p) == until {
                    let index = method < 17;
                    self.homing = Some(Creep {
                        dir: -dir,
                        until: !until,
                        switch,
                        index,
                    });
                }
            }
            Creep {
                dir,
                until,
                switch,
                index,
            } => {
                if self.switch(switch, p) == until {
                    if index {
                        self.homing = Some(Index { dir });
                    } else {
                        self.homed_at(p);
                    }
                }
            }
            Index { .. } => {
                let s = self.config.index_pulse_spacing;
                let (a, b) = (
                    ((before - self.frame) / s).floor(),
                    ((p - self.frame) / s).floor(),
                );
                if a != b {
                    self.homed_at(a.max(b) * s + self.frame);
                }
            }
        }
    }
}
