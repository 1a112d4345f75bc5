//! What the analyzer judges by rate: the bus load per second of log time, the SYNC period
//! (observed, then held against) and each PDO identifier's interval (a PDO that stops or
//! changes its rate).

use super::*;

impl Analyzer {
    /// Bus load per second of log time, at the configured bit rate.
    pub(super) fn load(&mut self, first: u64, time_us: u64, bits: u64) {
        let second = (time_us - first) / 1_000_000;
        if second != self.load_second {
            self.close_second();
            self.load_second = second;
            self.load_bits = 0;
        }
        self.load_bits += bits;
        self.total_bits += bits;
    }

    pub(super) fn close_second(&mut self) {
        let load = self.load_bits as f64 * 100.0 / f64::from(self.config.bitrate.max(1));
        let at = self.first_us.unwrap_or(0) + self.load_second * 1_000_000;
        if load > self.load_peak {
            self.load_peak = load;
            self.load_peak_at_us = at;
        }
        if load > self.config.load_threshold {
            self.problem(
                at,
                None,
                None,
                Level::Warning,
                Kind::BusLoad,
                format!(
                    "bus load {load:.1} % in the second from {} (at {} bit/s)",
                    self.rel(at),
                    self.config.bitrate
                ),
                format!(
                    "above {:.0} %: low-priority frames (SDO, heartbeats) wait for the bus and \
                     arrive late",
                    self.config.load_threshold
                ),
            );
        }
    }

    pub(super) fn sync(&mut self, line: usize, t: u64) {
        if let Some(last) = self.sync_last {
            let interval = t - last;
            if self.sync_lost {
                self.sync_lost = false;
                self.problem(
                    t,
                    Some(line),
                    None,
                    Level::Info,
                    Kind::SyncLost,
                    format!("SYNC again after {} ms", interval / 1000),
                    "the SYNC producer is back".into(),
                );
            } else if let Some(period) = self.sync_period {
                let off = interval.abs_diff(period);
                // Jitter under a quarter of the period (at least 1 ms) is a master's timer.
                if off > (period / 4).max(1000) {
                    self.problem(
                        t,
                        Some(line),
                        None,
                        Level::Warning,
                        Kind::SyncPeriod,
                        format!(
                            "SYNC {:.1} ms after the one before; period {:.1} ms",
                            interval as f64 / 1000.0,
                            period as f64 / 1000.0
                        ),
                        "synchronous PDOs are sampled and applied off their cycle: a busy \
                         SYNC producer or a loaded bus"
                            .into(),
                    );
                }
            } else {
                self.sync_intervals.push(interval);
                if self.sync_intervals.len() == 5 {
                    let mut v = std::mem::take(&mut self.sync_intervals);
                    v.sort_unstable();
                    self.sync_period = Some(v[2].max(1));
                }
            }
        }
        self.sync_last = Some(t);
    }

    pub(super) fn pdo(&mut self, line: usize, t: u64, raw: u16, frame: &CanFrame) {
        let mut rate_change = None;
        let p = self.pdos.entry(raw).or_default();
        let back = p.stopped;
        p.stopped = false;
        if p.count > 0 {
            let interval = (t - p.last) as f64;
            p.mean = if p.count == 1 {
                interval
            } else {
                p.mean * 0.9 + interval * 0.1
            };
            p.window_sum += t - p.last;
            p.window_n += 1;
            if p.window_n == 20 {
                let mean = p.window_sum as f64 / 20.0;
                if let Some(before) = p.window_mean
                    && before > 0.0
                    && (mean / before > 2.0 || before / mean > 2.0)
                {
                    rate_change = Some((before, mean));
                }
                p.window_mean = Some(mean);
                p.window_sum = 0;
                p.window_n = 0;
            }
        }
        p.count += 1;
        p.last = t;
        let node = u8::try_from(raw & 0x7F).ok();
        if back {
            let seen = self.seen(frame);
            self.problem(
                t,
                Some(line),
                node,
                Level::Info,
                Kind::PdoStopped,
                format!("{seen}: the PDO again"),
                "the PDO is sent again".into(),
            );
        }
        if let Some((before, after)) = rate_change {
            let seen = self.seen(frame);
            self.problem(
                t,
                Some(line),
                node,
                Level::Warning,
                Kind::PdoRate,
                format!(
                    "{seen}: every {:.1} ms, before every {:.1} ms",
                    after / 1000.0,
                    before / 1000.0
                ),
                "the PDO's rate changed: its event timer, inhibit time or SYNC changed, or the \
                 producer is overloaded"
                    .into(),
            );
        }
    }
}
