//! The `CanBus` trait every CAN back end implements, and the in-memory bus for tests.

use tokio::sync::broadcast;

use crate::link::Error;
use crate::proto::canopen::CanFrame;

/// One node's connection to a CAN bus: send frames, receive every frame others send.
#[allow(async_fn_in_trait)]
pub trait CanBus {
    /// Queue a frame for the bus.
    async fn send(&mut self, frame: &CanFrame) -> Result<(), Error>;
    /// The next frame from the bus (waits; wrap in a timeout).
    async fn recv(&mut self) -> Result<CanFrame, Error>;
    /// For messages: `can0`, `slcan /dev/ttyACM0 at 1 Mbit/s`, `memory bus`.
    fn describe(&self) -> String;
    /// Troubles the bus got over by itself since the last call (garbled lines skipped,
    /// lines the adapter refused, frames lost by a slow reader), each kind once with its
    /// count, for the user's log. The link hands them on through `Link::take_recovered`.
    fn take_troubles(&mut self) -> Vec<String> {
        Vec::new()
    }
    /// Where several links share the bus: a further port on it that hears every frame (a
    /// scan while nodes are open). `None` where this port hears every frame already.
    async fn listener(&self) -> Option<Result<super::SharedCanPort, Error>> {
        None
    }
    /// Where the bus keeps the frame log itself (shared by several links): every frame on
    /// it since the last call, in wire order. `None`: the link keeps its own.
    fn take_trace(&mut self) -> Option<Vec<crate::link::TraceRecord>> {
        None
    }
}

/// An in-memory CAN bus: every port receives what every other port sends. Cheap to clone
/// into as many nodes as a test needs.
#[derive(Clone, Debug)]
pub struct MemoryBus {
    tx: broadcast::Sender<(usize, CanFrame)>,
}

/// One node on a `MemoryBus`.
#[derive(Debug)]
pub struct MemoryPort {
    id: usize,
    tx: broadcast::Sender<(usize, CanFrame)>,
    rx: broadcast::Receiver<(usize, CanFrame)>,
    /// Frames this port was too slow to receive, not yet reported.
    lagged: u64,
}

impl MemoryBus {
    pub fn new() -> Self {
        let (tx, _) = broadcast::channel(4096);
        Self { tx }
    }

    /// Attach a node.
    pub fn port(&self) -> MemoryPort {
        static NEXT: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(1);
        MemoryPort {
            id: NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
            tx: self.tx.clone(),
            rx: self.tx.subscribe(),
            lagged: 0,
        }
    }
}

impl Default for MemoryBus {
    fn default() -> Self {
        Self::new()
    }
}

impl CanBus for MemoryPort {
    async fn send(&mut self, frame: &CanFrame) -> Result<(), Error> {
        // No other node listening is fine on a bus (nobody acknowledges; we do not model it).
        let _ = self.tx.send((self.id, *frame));
        Ok(())
    }

    async fn recv(&mut self) -> Result<CanFrame, Error> {
        loop {
            match self.rx.recv().await {
                Ok((from, frame)) if from != self.id => return Ok(frame),
                Ok(_) => {}
                Err(broadcast::error::RecvError::Lagged(n)) => {
                    tracing::debug!("memory CAN bus: {n} frames lost by a slow node");
                    self.lagged += n;
                }
                Err(broadcast::error::RecvError::Closed) => {
                    return Err(Error::Disconnected("the memory CAN bus is gone".into()));
                }
            }
        }
    }

    fn describe(&self) -> String {
        "memory bus".into()
    }

    fn take_troubles(&mut self) -> Vec<String> {
        match std::mem::take(&mut self.lagged) {
            0 => Vec::new(),
            n => vec![format!(
                "memory bus: {n} frame(s) lost, this node read too slowly"
            )],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test(flavor = "current_thread")]
    async fn every_other_node_hears_a_frame() {
        let bus = MemoryBus::new();
        let mut a = bus.port();
        let mut b = bus.port();
        let mut c = bus.port();
        let frame = CanFrame::new(0x701, &[0x00]).unwrap();
        a.send(&frame).await.unwrap();
        assert_eq!(b.recv().await.unwrap(), frame);
        assert_eq!(c.recv().await.unwrap(), frame);
        // The sender does not hear itself.
        let other = CanFrame::new(0x181, &[1, 2]).unwrap();
        b.send(&other).await.unwrap();
        assert_eq!(a.recv().await.unwrap(), other);
    }
}
