//! `canopen top --replay FILE`: a candump log fed to the model with its recorded timing, which
//! the keys pause, step one frame at a time, and move 10 s forward or back (back rebuilds the
//! model from the log's start, as the model only moves forward).

use std::path::Path;

use canola::candump::{self, LogFrame};
use canola::{Instant, NodeId, ObjectDictionary};

use super::Recording;
use super::model::Model;
use super::tap::Seen;
use crate::error::CliError;

/// A log being replayed. See the module docs.
pub(crate) struct Replay {
    /// Time stamps (µs, as the log has them) and frames, in the log's order.
    frames: Vec<(u64, LogFrame)>,
    /// The next frame to feed.
    pos: usize,
    /// Log time of the first frame.
    t0: u64,
    /// Replay position: log time since `t0`, µs.
    clock: u64,
    playing: bool,
    /// Wall time of the last advance.
    last: std::time::Instant,
    dictionaries: Vec<(NodeId, ObjectDictionary)>,
    bitrate: u32,
}

impl Replay {
    /// Reads the whole log (a bad line is an error naming it).
    pub(crate) fn load(
        file: &Path,
        dictionaries: Vec<(NodeId, ObjectDictionary)>,
        bitrate: u32,
    ) -> Result<Self, CliError> {
        let f = std::fs::File::open(file).map_err(CliError::file(file))?;
        let mut frames = Vec::new();
        for entry in candump::Reader::new(std::io::BufReader::new(f)) {
            let e = entry.map_err(|source| CliError::Log {
                path: file.to_owned(),
                source,
                nothing_sent: false,
            })?;
            frames.push((e.timestamp_us, e.frame));
        }
        Ok(Self::new(frames, dictionaries, bitrate))
    }

    /// A replay of `frames` (time stamps in µs).
    pub(crate) fn new(
        frames: Vec<(u64, LogFrame)>,
        dictionaries: Vec<(NodeId, ObjectDictionary)>,
        bitrate: u32,
    ) -> Self {
        let t0 = frames.first().map_or(0, |f| f.0);
        Self {
            frames,
            pos: 0,
            t0,
            clock: 0,
            playing: true,
            last: std::time::Instant::now(),
            dictionaries,
            bitrate,
        }
    }

    pub(crate) fn playing(&self) -> bool {
        self.playing
    }

    pub(crate) fn toggle(&mut self) {
        self.playing = !self.playing;
        self.last = std::time::Instant::now();
    }

    /// Length of the log, µs.
    fn length(&self) -> u64 {
        self.frames
            .last()
            .map_or(0, |f| f.0.saturating_sub(self.t0))
    }

    /// `12.3 s of 60.0 s, frame 120 of 4000, playing`.
    pub(crate) fn position_text(&self) -> String {
        let state = if self.pos == self.frames.len() {
            "end of log"
        } else if self.playing {
            "playing"
        } else {
            "paused"
        };
        format!(
            "{:.1} s of {:.1} s, frame {} of {}, {state}",
            self.clock as f64 / 1e6,
            self.length() as f64 / 1e6,
            self.pos,
            self.frames.len()
        )
    }

    /// Feeds the frames up to the clock.
    fn feed_to_clock(&mut self, model: &mut Model, rec: &mut Recording) {
        while let Some(&(ts, frame)) = self.frames.get(self.pos) {
            let at = ts.saturating_sub(self.t0);
            if at > self.clock {
                break;
            }
            self.feed(at, ts, frame, model, rec);
        }
        model.tick(Instant::from_micros(self.clock));
    }

    fn feed(&mut self, at: u64, ts: u64, frame: LogFrame, model: &mut Model, rec: &mut Recording) {
        model.ingest(&Seen::Frame {
            at: Instant::from_micros(at),
            frame,
            sent: false,
        });
        rec.push(ts, frame);
        self.pos += 1;
    }

    /// Lets the wall time since the last call pass (while playing) and feeds what it covers.
    pub(crate) fn advance(&mut self, model: &mut Model, rec: &mut Recording) {
        let now = std::time::Instant::now();
        if self.playing {
            let dt = now.saturating_duration_since(self.last).as_micros() as u64;
            self.clock = (self.clock + dt).min(self.length());
        }
        self.last = now;
        self.feed_to_clock(model, rec);
    }

    /// One frame forward (pauses the replay).
    pub(crate) fn step(&mut self, model: &mut Model, rec: &mut Recording) {
        self.playing = false;
        if let Some(&(ts, frame)) = self.frames.get(self.pos) {
            let at = ts.saturating_sub(self.t0);
            self.clock = self.clock.max(at);
            self.feed(at, ts, frame, model, rec);
            model.tick(Instant::from_micros(self.clock));
        }
    }

    /// `secs` forward or back.
    pub(crate) fn seek(&mut self, secs: i32, model: &mut Model, rec: &mut Recording) {
        let d = u64::from(secs.unsigned_abs()) * 1_000_000;
        if secs >= 0 {
            self.clock = (self.clock + d).min(self.length());
        } else {
            self.clock = self.clock.saturating_sub(d);
            *model = Model::new(&self.dictionaries, self.bitrate);
            rec.frames.clear();
            rec.dropped = 0;
            self.pos = 0;
        }
        self.last = std::time::Instant::now();
        self.feed_to_clock(model, rec);
    }
}
