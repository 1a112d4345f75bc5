//! The async API (`tokio` feature): the same requests as the blocking [`Sdo`], as
//! futures.
//!
//! Each future submits its request to the one core, then waits for it on tokio's blocking pool
//! with the blocking driver loop (so there is no second protocol implementation and no second
//! driving loop). Dropping the future before it completes cancels the request: a queued request
//! is removed, a running transfer is aborted on the bus (0x08000000) and the node is free for the
//! next request at once; the abandoned transfer's late responses are ignored.

use can_frame::NodeId;

use crate::core::{Completion, Entry, RequestId};
use crate::error::{Error, SdoError, SdoErrorKind};
use crate::network::{Network, Pending, Sdo, SdoValue};

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

async fn wait_async(pending: Pending) -> Result<Completion, SdoError> {
    let (net, id) = pending.into_parts();
    let Some(id) = id else {
        return Err(cancelled());
    };
    let mut guard = CancelGuard {
        net: net.clone(),
        id: Some(id),
    };
    let waiter = net.clone();
    let r = tokio::task::spawn_blocking(move || waiter.wait(id)).await;
    guard.id = None;
    r.unwrap_or_else(|_| Err(cancelled()))
}

fn cancelled() -> SdoError {
    SdoError {
        node: NodeId::MIN,
        entry: Entry::new(0, 0),
        name: None,
        kind: SdoErrorKind::Cancelled,
    }
}

impl Sdo {
    /// Reads an object's bytes (async). Dropping the future cancels the transfer.
    pub async fn read_async(self, entry: impl Into<Entry>) -> Result<Vec<u8>, Error> {
        match wait_async(self.submit_read(entry)).await? {
            Completion::Data(v) => Ok(v),
            _ => Ok(Vec::new()),
        }
    }

    /// Writes an object (async). Dropping the future cancels the transfer.
    pub async fn write_async(
        self,
        entry: impl Into<Entry>,
        value: impl SdoValue,
    ) -> Result<(), Error> {
        wait_async(self.submit_write(entry, value)).await?;
        Ok(())
    }
}

impl Pending {
    /// Waits for the request without blocking the async runtime. Dropping the future cancels it.
    pub async fn wait_async(self) -> Result<Completion, SdoError> {
        wait_async(self).await
    }
}
