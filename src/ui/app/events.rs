//! The workers' news: every drive's events applied to its model, every frame, whichever
//! drive is shown; what a drive's event means for the whole window (a capture to show)
//! applied to the window.

use super::App;
use crate::ui::drive::News;
use crate::ui::plots::model::capture_span;

impl App {
    /// Apply every drive's waiting events at the window's clock `clock`. A trigger that
    /// fired on the drive shown freezes the plots on its capture; one that fired on
    /// another drive pauses them at the end of that capture, so it shows every drive's
    /// signals.
    pub(super) fn pump_drives(&mut self, clock: f64) {
        for (i, slot) in self.drives.iter_mut().enumerate() {
            let drive = &mut slot.drive;
            drive.clock = clock;
            for event in slot.channel.drain() {
                match drive.apply(event) {
                    Some(News::Captured(text)) if i == self.selected => {
                        self.window.plot.captured(text, &drive.scope);
                    }
                    Some(News::Captured(_)) => {
                        if let Some((at, span)) = capture_span(drive) {
                            self.window.plot.frozen_by(&drive.name, at, span);
                        }
                    }
                    None => {}
                }
            }
            drive.panels.tick(clock);
        }
    }
}
