//! The link's SDO transfers: one request at a time, sent again within its budget when an
//! answer is lost, garbled or breaks the protocol (see [`super::SDO_TIMEOUT`]).

use std::time::{Duration, Instant};

use super::{CanopenLink, RECOVERED_KEPT, SDO_TIMEOUT, SDO_TRY};
use crate::cia::AbortCode;
use crate::link::Error;
use crate::link::canopen::CanBus;
use crate::link::tries::{TRIES, Trouble, gave_up, silence};
use crate::od::Address;
use crate::proto::canopen::CanFrame;
use crate::proto::canopen::sdo::{SdoClient, SdoEvent};

impl<B: CanBus> CanopenLink<B> {
    /// Receive until the SDO client makes something of a frame (`Some`), or `deadline`
    /// passes (`None`); every other frame is handled as unsolicited.
    pub(super) async fn await_sdo(&mut self, deadline: Instant) -> Result<Option<SdoEvent>, Error> {
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let frame = match tokio::time::timeout(left, self.bus.recv()).await {
                Err(_) => return Ok(None),
                Ok(frame) => frame?,
            };
            self.trace(false, &frame);
            match self.sdo.on_frame(&frame) {
                SdoEvent::Ignored => self.unsolicited(&frame),
                event => return Ok(Some(event)),
            }
        }
    }

    /// Run one SDO transfer to its end, `start` (the client's upload or download) sending
    /// its first frame, up to [`TRIES`] times as [`SDO_TIMEOUT`] says. The drive's abort is
    /// `Ok(Err(code))`; every try gone wrong is an error naming what each met.
    pub(super) async fn sdo_transfer(
        &mut self,
        what: &str,
        start: impl Fn(&mut SdoClient) -> CanFrame,
    ) -> Result<Result<Vec<u8>, AbortCode>, Error> {
        let what = format!("{what} from node {}", self.options.node);
        let mut troubles = Vec::new();
        for attempt in 1..=TRIES {
            // Frames that arrived before this try (a TPDO, an EMCY, a stale answer to an
            // earlier request) are not its answer.
            self.drain(Duration::ZERO).await?;
            let first = start(&mut self.sdo);
            match self.sdo_try(first, &mut troubles).await {
                Ok(answer) => {
                    if !troubles.is_empty() {
                        let on = if attempt > 1 {
                            format!(" (answered on try {attempt})")
                        } else {
                            String::new()
                        };
                        self.got_over(format!("{what}: {}{on}", troubles.join("; ")));
                    }
                    return Ok(answer);
                }
                Err(Trouble::Retry(trouble)) => troubles.push(trouble),
                Err(Trouble::Fatal(error)) => return Err(error),
            }
        }
        Err(gave_up(
            format!("{what} on {}", self.bus.describe()),
            troubles,
            SDO_TIMEOUT,
            "",
        ))
    }

    /// One try of an SDO transfer: `first` sent, then each answer awaited for [`SDO_TRY`].
    /// Late answers to earlier requests, skipped, are added to `notes`.
    pub(super) async fn sdo_try(
        &mut self,
        first: CanFrame,
        notes: &mut Vec<String>,
    ) -> Result<Result<Vec<u8>, AbortCode>, Trouble> {
        self.send(&first).await.map_err(Trouble::Fatal)?;
        let mut sent_at = Instant::now();
        loop {
            let event = self
                .await_sdo(sent_at + SDO_TRY)
                .await
                .map_err(Trouble::Fatal)?;
            match event {
                None => {
                    // Tell the drive we gave up, so its server is free again (a failed
                    // send shows in the next try's).
                    if let Some(abort) = self.sdo.abort(AbortCode::SDO_TIMEOUT) {
                        let _ = self.send(&abort).await;
                    }
                    return Err(silence(sent_at, None));
                }
                Some(SdoEvent::Send(next)) => {
                    self.send(&next).await.map_err(Trouble::Fatal)?;
                    sent_at = Instant::now();
                }
                Some(SdoEvent::Uploaded(data)) => return Ok(Ok(data)),
                Some(SdoEvent::Downloaded) => return Ok(Ok(vec![])),
                Some(SdoEvent::Aborted(code)) => return Ok(Err(code)),
                Some(SdoEvent::Stale(note)) => notes.push(note),
                Some(SdoEvent::Protocol(problem)) => {
                    if let Some(abort) = self.sdo.take_abort() {
                        let _ = self.send(&abort).await;
                    }
                    return Err(Trouble::Retry(format!(
                        "a reply that breaks the SDO protocol ({problem}): aborted"
                    )));
                }
                Some(SdoEvent::Ignored) => {}
            }
        }
    }

    /// Keep a trouble got over for `take_recovered`, boundedly.
    pub(super) fn got_over(&mut self, trouble: String) {
        if self.recovered.len() < RECOVERED_KEPT {
            self.recovered.push(trouble);
        } else {
            self.recovered_dropped += 1;
        }
    }

    pub(super) async fn sdo_upload(
        &mut self,
        index: u16,
        sub: u8,
    ) -> Result<Result<Vec<u8>, AbortCode>, Error> {
        self.sdo_transfer(
            &format!("SDO upload of {}", Address::new(index, sub)),
            |sdo| sdo.upload(index, sub),
        )
        .await
    }

    pub(super) async fn sdo_download(
        &mut self,
        index: u16,
        sub: u8,
        data: &[u8],
    ) -> Result<Result<(), AbortCode>, Error> {
        Ok(self
            .sdo_transfer(
                &format!("SDO download to {}", Address::new(index, sub)),
                |sdo| sdo.download(index, sub, data),
            )
            .await?
            .map(|_| ()))
    }
}
