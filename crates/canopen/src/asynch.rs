//! The async API (`tokio` feature): the same requests as the blocking [`Sdo`], as
//! futures.
//!
//! Each future submits its request to the one core, then waits for it on tokio's blocking pool
//! with the blocking driver loop (so there is no second protocol implementation and no second
//! driving loop). Dropping the future before it completes cancels the request: a queued request
//! is removed, a running transfer is aborted on the bus (0x08000000) and the node is free for the
//! next request at once; the abandoned transfer's late responses are ignored.

use crate::core::RequestId;
use crate::error::{Error, SdoError};
use crate::network::{Network, Pending, Sdo, SdoValue};
use canopen_od::ObjectAddress;

/// Cancels the request when dropped unless disarmed.
struct CancelGuard {
    net: Network,
    id: Option<RequestId>,
}

impl Drop for CancelGuard {
    fn drop(&mut self) {
        if let Some(id) = self.id.take() {
            self.net.cancel(id);
        }
    }
}

async fn wait_async<T>(mut pending: Pending<T>) -> Result<T, SdoError> {
    let Some(id) = pending.id.take() else {
        return Err(pending.cancelled());
    };
    let (net, node, entry, output) = (
        pending.net.clone(),
        pending.node,
        pending.entry,
        pending.output,
    );
    let mut guard = CancelGuard {
        net: net.clone(),
        id: Some(id),
    };
    let r = tokio::task::spawn_blocking(move || net.wait(id, node, entry)).await;
    guard.id = None;
    match r {
        Ok(r) => r.map(output),
        Err(_) => Err(pending.cancelled()),
    }
}

impl Sdo {
    /// Reads an object's bytes (async). Dropping the future cancels the transfer.
    pub async fn read_async(self, entry: impl Into<ObjectAddress>) -> Result<Vec<u8>, Error> {
        Ok(wait_async(self.submit_read(entry)).await?)
    }

    /// Writes an object (async). Dropping the future cancels the transfer.
    pub async fn write_async(
        self,
        entry: impl Into<ObjectAddress>,
        value: impl SdoValue,
    ) -> Result<(), Error> {
        Ok(wait_async(self.submit_write(entry, value)).await?)
    }
}

impl<T> Pending<T> {
    /// Waits for the request without blocking the async runtime. Dropping the future cancels it.
    pub async fn wait_async(self) -> Result<T, SdoError> {
        wait_async(self).await
    }
}
