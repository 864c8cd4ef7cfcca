//! `canopen+sim`: the built-in simulated drive as a CANopen node on an in-memory CAN bus,
//! so the whole CANopen path (NMT, SDO, PDO mapping, PDOs, EMCY) runs without hardware.

use crate::link::Error;
use crate::link::canopen::{CanBus, MemoryBus, MemoryPort};
use crate::proto::canopen::CanFrame;
use crate::sim::Drive;
use crate::sim::server::SharedDrive;

/// The master's port on a private in-memory bus with a simulated node on it. The node runs
/// as a task on the caller's runtime and stops when this bus is dropped.
#[derive(Debug)]
pub struct SimCanBus {
    port: MemoryPort,
    node: tokio::task::AbortHandle,
    drive: SharedDrive,
}

impl SimCanBus {
    /// A bus with a fresh simulated drive as node `node`. Call inside a tokio runtime.
    pub fn start(node: u8) -> SimCanBus {
        let bus = MemoryBus::new();
        let port = bus.port();
        let drive = SharedDrive::new(Drive::new());
        let served = drive.clone();
        let node_port = bus.port();
        let task = tokio::spawn(async move {
            let _ = crate::sim::server::canopen::run(node_port, node, served).await;
        });
        SimCanBus {
            port,
            node: task.abort_handle(),
            drive,
        }
    }

    /// Inject or withdraw a fault in the simulated node (a link loss is simulated on the
    /// in-process link only).
    pub fn inject(&mut self, injection: crate::sim::Injection, active: bool) -> Result<(), Error> {
        if injection.is_link() {
            return Err(Error::Unsupported(
                "a link loss is simulated on the in-process simulator link (sim), not on the CAN bus".into(),
            ));
        }
        let mut drive = self.drive.lock();
        if active {
            drive.inject(injection);
        } else {
            drive.withdraw(injection);
        }
        Ok(())
    }

    /// The simulated drive behind the node.
    pub fn drive(&self) -> &SharedDrive {
        &self.drive
    }
}

impl Drop for SimCanBus {
    fn drop(&mut self) {
        self.node.abort();
    }
}

impl CanBus for SimCanBus {
    async fn send(&mut self, frame: &CanFrame) -> Result<(), Error> {
        self.port.send(frame).await
    }

    async fn recv(&mut self) -> Result<CanFrame, Error> {
        self.port.recv().await
    }

    fn describe(&self) -> String {
        "the simulated CAN bus".into()
    }

    fn take_troubles(&mut self) -> Vec<String> {
        self.port.take_troubles()
    }
}
