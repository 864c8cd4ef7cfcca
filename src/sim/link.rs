//! The in-process link to the simulated drive. It owns the drive and advances it to the
//! present on every call, so the simulation runs on real time without a thread of its own,
//! or on a manual clock in tests.

use std::time::{Duration, Instant};

/// Now, on the clock of the runtime the link runs on: the wall clock, or tokio's paused
/// clock when a test runs the worker on simulated time.
fn now() -> Instant {
    tokio::time::Instant::now().into_std()
}

use crate::link::{Answer, Error, Exchange, Link, LinkInfo, LinkSpec, Refusal, Signal, Signals};
use crate::od::{Address, DataType, Value};
use crate::pdi::RxImage;
use crate::sim::{Drive, Injection};

/// The longest stretch the drive is advanced in one go. A real drive runs on whatever the
/// master does, so the simulation keeps real time through stalls and link losses; only a
/// machine that slept (a laptop lid) is not replayed in full.
const MAX_CATCH_UP: Duration = Duration::from_secs(60);

/// How long an injected link loss lasts before the "cable" is back.
pub const LINK_LOSS_TIME: Duration = Duration::from_secs(3);

/// How the drive's time advances.
#[derive(Clone, Copy, Debug)]
pub enum Clock {
    /// Wall-clock time.
    Real { last: Instant },
    /// Only by `SimLink::advance` (tests).
    Manual,
}

/// The simulated drive behind a `Link`.
#[derive(Debug)]
pub struct SimLink {
    drive: Drive,
    clock: Clock,
    /// A simulated cable pull: every call fails until then.
    cut_until: Option<Instant>,
}

impl SimLink {
    /// Inject or withdraw a fault: in the drive, or (a link loss) in the simulated cable.
    pub fn inject(&mut self, injection: Injection, active: bool) -> Result<(), Error> {
        if injection.is_link() {
            self.cut_until = active.then(|| now() + LINK_LOSS_TIME);
            return Ok(());
        }
        self.catch_up()?;
        if active {
            self.drive.inject(injection);
        } else {
            self.drive.withdraw(injection);
        }
        Ok(())
    }

    /// A fresh simulated drive on real time.
    pub fn new() -> Self {
        Self::with_drive(Drive::new())
    }

    pub fn with_drive(drive: Drive) -> Self {
        Self {
            drive,
            clock: Clock::Real { last: now() },
            cut_until: None,
        }
    }

    /// A drive whose time moves only by `advance`.
    pub fn manual(drive: Drive) -> Self {
        Self {
            drive,
            clock: Clock::Manual,
            cut_until: None,
        }
    }

    pub fn advance(&mut self, dt: Duration) {
        self.drive.tick(dt);
    }

    pub fn drive(&self) -> &Drive {
        &self.drive
    }

    pub fn drive_mut(&mut self) -> &mut Drive {
        &mut self.drive
    }

    /// Bring the drive to the present; fails while the cable is "pulled".
    fn catch_up(&mut self) -> Result<(), Error> {
        // The drive runs on while the cable is out.
        self.advance_clock();
        self.check_cable()
    }

    fn check_cable(&mut self) -> Result<(), Error> {
        if self.drive.rebooting() {
            return Err(Error::Disconnected(
                "no answer: the simulated drive is restarting".into(),
            ));
        }
        match self.cut_until {
            Some(until) if now() < until => Err(Error::Disconnected(
                "no answer: the simulated cable is pulled (injected link loss)".into(),
            )),
            Some(_) => {
                self.cut_until = None;
                Ok(())
            }
            None => Ok(()),
        }
    }

    fn advance_clock(&mut self) {
        if let Clock::Real { last } = &mut self.clock {
            let now = now();
            let elapsed = now.saturating_duration_since(*last).min(MAX_CATCH_UP);
            *last = now;
            self.drive.tick(elapsed);
        }
    }
}

impl Default for SimLink {
    fn default() -> Self {
        Self::new()
    }
}

impl Link for SimLink {
    fn info(&self) -> LinkInfo {
        LinkInfo {
            spec: LinkSpec::Sim,
            description: "Simulated drive (in-process)".into(),
            native_objects: true,
            can_inject: true,
            pdi: true,
            homing_methods: Some(crate::sim::SUPPORTED_METHODS.to_vec()),
            commands_refused: None,
        }
    }

    async fn exchange(&mut self, rx: Option<&RxImage>) -> Result<Exchange, Error> {
        self.catch_up()?;
        if let Some(rx) = rx {
            self.drive.write_rx(rx);
        }
        // The simulator has every signal at hand: all of them, every cycle.
        let mut signals = Signals::default();
        for signal in Signal::ALL {
            if let Some(v) = self
                .drive
                .read(signal.address())
                .ok()
                .and_then(|v| v.as_f64())
            {
                signals.set(signal, v);
            }
        }
        Ok(Exchange {
            tx: self.drive.tx_image(),
            signals,
        })
    }

    async fn read_rx(&mut self) -> Result<Option<RxImage>, Error> {
        self.catch_up()?;
        Ok(Some(self.drive.rx_image()))
    }

    async fn read_object(&mut self, address: Address, _dtype: DataType) -> Answer<Value> {
        self.catch_up()?;
        Ok(self.drive.read(address).map_err(Refusal::Abort))
    }

    async fn write_object(
        &mut self,
        address: Address,
        dtype: DataType,
        value: &Value,
    ) -> Answer<()> {
        self.catch_up()?;
        // The value travels in the caller's type, as it would on a bus: a mismatch with the
        // drive's own type is the drive's refusal, as an SDO server would answer.
        if let Some(entry) = self.drive.entry(address)
            && entry.dtype != dtype
            && entry.dtype.size() != dtype.size()
        {
            return Ok(Err(Refusal::Abort(
                crate::cia::AbortCode::TYPE_LENGTH_MISMATCH,
            )));
        }
        Ok(self
            .drive
            .write(address, value.clone())
            .map_err(Refusal::Abort))
    }

    async fn reconnect(&mut self) -> Result<(), Error> {
        self.catch_up()
    }
}
