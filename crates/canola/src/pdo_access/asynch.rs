//! The async twins of the PDO handles' calls (`tokio` feature), over the same sequences.

use canola_pdo::Direction;

use crate::error::Error;
use crate::typed::{ObjectKey, WriteValue};

use super::handles::{Rpdos, Tpdos};
use super::params::{PdoParameters, PdoSet};
use super::sequence::{Port, read_set, save_set};
use super::transmit::{RpdoSender, Transmission};

use crate::asynch::drive;

impl Tpdos {
    /// Reads every TPDO's parameters (async [`read`](Tpdos::read)).
    pub async fn read_async(&self) -> Result<PdoSet, Error> {
        drive::catch_up(&self.node.net)?;
        read_set(Port::Async(&self.node), Direction::Transmit).await
    }

    /// Writes the TPDOs changed since they were read (async [`save`](Tpdos::save)).
    pub async fn save_async(&self, set: &mut PdoSet) -> Result<(), Error> {
        drive::catch_up(&self.node.net)?;
        save_set(Port::Async(&self.node), Direction::Transmit, set).await
    }
}

impl Rpdos {
    /// Reads every RPDO's parameters (async [`read`](Rpdos::read)).
    pub async fn read_async(&self) -> Result<PdoSet, Error> {
        drive::catch_up(&self.node.net)?;
        read_set(Port::Async(&self.node), Direction::Receive).await
    }

    /// Writes the RPDOs changed since they were read (async [`save`](Rpdos::save)).
    pub async fn save_async(&self, set: &mut PdoSet) -> Result<(), Error> {
        drive::catch_up(&self.node.net)?;
        save_set(Port::Async(&self.node), Direction::Receive, set).await
    }

    /// Transmits the node's RPDO `pdo` from the master (async [`start`](Rpdos::start)).
    pub async fn start_async(
        &self,
        pdo: &PdoParameters,
        how: Transmission,
    ) -> Result<RpdoSender, Error> {
        drive::catch_up(&self.node.net)?;
        let sender = self.engage(pdo, how)?;
        drive::flush(&self.node.net).await?;
        Ok(sender)
    }
}

impl RpdoSender {
    /// Sets one mapped value (async [`set`](RpdoSender::set)).
    pub async fn set_async<'k>(
        &self,
        key: impl Into<ObjectKey<'k>>,
        value: impl Into<WriteValue>,
    ) -> Result<(), Error> {
        self.set_many_async([(key, value)]).await
    }

    /// Sets several mapped values at once (async [`set_many`](RpdoSender::set_many)).
    pub async fn set_many_async<'k, K, V>(
        &self,
        values: impl IntoIterator<Item = (K, V)>,
    ) -> Result<(), Error>
    where
        K: Into<ObjectKey<'k>>,
        V: Into<WriteValue>,
    {
        drive::catch_up(&self.node.net)?;
        self.stage(values)?;
        drive::flush(&self.node.net).await
    }

    /// Sends the RPDO now (async [`trigger`](RpdoSender::trigger)).
    pub async fn trigger_async(&self) -> Result<(), Error> {
        drive::catch_up(&self.node.net)?;
        self.queue_trigger()?;
        drive::flush(&self.node.net).await
    }
}
