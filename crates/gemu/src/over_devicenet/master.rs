//! The cPos client driven through a DeviceNet master.
//!
//! Call order (sans-IO, like the machines inside): [`CposMaster::handle_frame`] for every
//! received frame, [`CposMaster::handle_timeout`] when [`CposMaster::poll_timeout`] has passed,
//! then drain [`CposMaster::poll_transmit`] and [`CposMaster::poll_event`]. Queue requests on
//! [`CposMaster::client_mut`] once [`CposEvent::Connected`] has come.

use canola_devicenet::explicit::Path;
use canola_devicenet::master::{ConnectError, Handle};
use canola_devicenet::{
    DuplicateMacCheck, Identity, Master, MasterConfig, MasterEvent, MasterState,
};
use canola_frame::{CanFrame, Instant, is_due};
use heapless::Deque;

use super::{ImageSizes, SizeError};
use crate::channel::{Channel, DiagnosticCode};
use crate::client::{Client, ClientConfig, Event};
use crate::image::{DeviceImage, DigitalOutputs, ImageError, PerMille};

/// Settings.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CposMasterConfig {
    /// The DeviceNet master (own MAC, the cPos's MAC, poll cycle, timeouts).
    pub master: MasterConfig,
    /// The client's timeouts.
    pub client: ClientConfig,
    /// Sizes the application requires; `None` accepts any size the cPos offers.
    pub expected_sizes: Option<ImageSizes>,
    /// Attribute with the latest external diagnostic code (see the module docs).
    pub diagnostics: Option<Path>,
}

impl CposMasterConfig {
    /// Defaults for a cPos at `slave`: standard sizes expected, no diagnostic attribute.
    pub fn new(slave: canola_devicenet::MacId) -> Self {
        Self {
            master: MasterConfig::new(slave),
            client: ClientConfig::default(),
            expected_sizes: Some(ImageSizes::STANDARD),
            diagnostics: None,
        }
    }
}

/// What the DeviceNet side reports; the client's own events come as [`CposEvent::Client`].
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum CposEvent {
    /// Connected; the identity and the sizes the device is set to.
    Connected {
        /// Identity object.
        identity: Identity,
        /// Image sizes.
        sizes: ImageSizes,
    },
    /// The device's sizes do not fit: the master released the connection and stays
    /// disconnected.
    SizeMismatch(SizeError),
    /// A connect attempt failed (retried).
    ConnectFailed(ConnectError),
    /// The connection was lost (the master reconnects).
    ConnectionLost,
    /// Another station uses the master's MAC ID: the master is faulted.
    DuplicateMac(DuplicateMacCheck),
    /// The device's image does not decode.
    BadImage(ImageError),
    /// A client event.
    Client(Event),
}

/// The client over DeviceNet.
#[derive(Debug)]
pub struct CposMaster {
    config: CposMasterConfig,
    master: Master,
    client: Client,
    sizes: Option<ImageSizes>,
    /// The image waiting for its diagnostic read, and the read.
    held: Option<(DeviceImage, Option<Handle>)>,
    last_channel: Channel,
    events: Deque<CposEvent, 64>,
}

impl CposMaster {
    /// A master; call [`CposMaster::start`] to go on line.
    pub fn new(config: CposMasterConfig) -> Self {
        Self {
            master: Master::new(config.master.clone()),
            client: Client::new(config.client),
            config,
            sizes: None,
            held: None,
            last_channel: Channel::default(),
            events: Deque::new(),
        }
    }

    /// Starts the Duplicate MAC ID check and the connection.
    pub fn start(&mut self, now: Instant) {
        self.master.start(now);
    }

    /// Releases the connection (the frames to send are in [`CposMaster::poll_transmit`]); the
    /// master stays disconnected.
    pub fn disconnect(&mut self, now: Instant) {
        self.master.disconnect(now);
        self.sizes = None;
        self.held = None;
    }

    /// The client (queue requests here).
    pub fn client_mut(&mut self) -> &mut Client {
        &mut self.client
    }
    /// The client.
    pub fn client(&self) -> &Client {
        &self.client
    }
    /// The DeviceNet master.
    pub fn master(&self) -> &Master {
        &self.master
    }
    /// Whether the poll connection is established with fitting sizes.
    pub fn is_connected(&self) -> bool {
        self.sizes.is_some() && self.master.state() == MasterState::Connected
    }
    /// The sizes of the established connection.
    pub fn sizes(&self) -> Option<ImageSizes> {
        self.sizes
    }
    /// Whether the images carry the parameter channel (send 13 and receive 11).
    pub fn has_channel(&self) -> bool {
        self.sizes.is_some_and(|s| s.send == 13 && s.receive == 11)
    }

    fn event(&mut self, e: CposEvent) {
        if self.events.is_full() {
            self.events.pop_front();
        }
        let _ = self.events.push_back(e);
    }

    fn update_output(&mut self) {
        let bytes = self.client.image().to_bytes();
        let n = self.sizes.map_or(0, |s| s.send as usize).min(bytes.len());
        self.master.set_output(&bytes[..n]);
    }

    /// Widens the received bytes to the 11-byte image: a shorter setting keeps the last channel
    /// (and zero outputs).
    fn widen(&self, data: &[u8]) -> Result<Option<DeviceImage>, ImageError> {
        match data.len() {
            11 => DeviceImage::parse(data).map(Some),
            2 | 3 => {
                let position = PerMille::new(u16::from_be_bytes([data[0], data[1]]))?;
                let outputs = match data.get(2) {
                    Some(&b) => DigitalOutputs::from_byte(b)?,
                    None => DigitalOutputs::default(),
                };
                Ok(Some(DeviceImage {
                    position,
                    outputs,
                    channel: self.last_channel,
                }))
            }
            0 => Ok(None),
            n => Err(ImageError::Length {
                expected: 11,
                actual: n,
            }),
        }
    }

    fn feed(&mut self, now: Instant, image: DeviceImage, diagnostic: Option<DiagnosticCode>) {
        if let Some(d) = diagnostic {
            self.client.handle_diagnostic(now, d);
        }
        self.last_channel = image.channel;
        self.client.handle_image(now, &image);
        self.drain_client();
    }

    fn drain_client(&mut self) {
        while let Some(e) = self.client.poll_event() {
            self.event(CposEvent::Client(e));
        }
        self.update_output();
    }

    fn input(&mut self, now: Instant, data: &[u8]) {
        let image = match self.widen(data) {
            Ok(Some(i)) => i,
            Ok(None) => return,
            Err(e) => return self.event(CposEvent::BadImage(e)),
        };
        if let Some((held, _)) = &mut self.held {
            *held = image;
            return;
        }
        match self.config.diagnostics {
            Some(path) if image.channel != self.last_channel => {
                match self.master.get_attribute(now, path) {
                    Ok(h) => self.held = Some((image, Some(h))),
                    Err(_) => self.feed(now, image, None),
                }
            }
            _ => self.feed(now, image, None),
        }
    }

    fn drain_master(&mut self, now: Instant) {
        while let Some(e) = self.master.poll_event() {
            match e {
                MasterEvent::Connected {
                    identity,
                    produced_size,
                    consumed_size,
                } => {
                    let actual = ImageSizes {
                        send: consumed_size,
                        receive: produced_size,
                    };
                    let checked = actual
                        .check()
                        .and_then(|s| match self.config.expected_sizes {
                            Some(expected) if expected != s => {
                                Err(SizeError::Unexpected { expected, actual })
                            }
                            _ => Ok(s),
                        });
                    match checked {
                        Ok(sizes) => {
                            self.sizes = Some(sizes);
                            self.update_output();
                            self.event(CposEvent::Connected { identity, sizes });
                        }
                        Err(e) => {
                            self.master.disconnect(now);
                            self.event(CposEvent::SizeMismatch(e));
                        }
                    }
                }
                MasterEvent::Input(data) => self.input(now, &data),
                MasterEvent::ExplicitDone { handle, result } => {
                    if let Some((image, Some(h))) = self.held
                        && h == handle
                    {
                        self.held = None;
                        let code = result
                            .ok()
                            .and_then(|d| d.first().copied())
                            .filter(|&c| c != 0)
                            .map(DiagnosticCode);
                        self.feed(now, image, code);
                    }
                }
                MasterEvent::ConnectionLost => {
                    self.sizes = None;
                    self.held = None;
                    self.event(CposEvent::ConnectionLost);
                }
                MasterEvent::ConnectFailed(e) => self.event(CposEvent::ConnectFailed(e)),
                MasterEvent::DuplicateMac(c) => self.event(CposEvent::DuplicateMac(c)),
                MasterEvent::Online => {}
            }
        }
    }

    /// Feeds a received frame.
    pub fn handle_frame(&mut self, now: Instant, frame: &CanFrame) {
        self.master.handle_frame(now, frame);
        self.drain_master(now);
    }

    /// Fires due timers (the master's and the client's).
    pub fn handle_timeout(&mut self, now: Instant) {
        if is_due(self.master.poll_timeout(), now) {
            self.master.handle_timeout(now);
            self.drain_master(now);
        }
        if is_due(self.client.poll_timeout(), now) {
            self.client.handle_timeout(now);
            self.drain_client();
        }
    }

    /// The next deadline.
    #[must_use]
    pub fn poll_timeout(&self) -> Option<Instant> {
        match (self.master.poll_timeout(), self.client.poll_timeout()) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// The next frame to send.
    #[must_use]
    pub fn poll_transmit(&mut self) -> Option<CanFrame> {
        self.master.poll_transmit()
    }

    /// The next event.
    #[must_use]
    pub fn poll_event(&mut self) -> Option<CposEvent> {
        self.events.pop_front()
    }
}
