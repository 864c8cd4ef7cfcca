//! What the browser says about the last thing done, in the colour of its outcome, and
//! whose link it is: values, previews and messages belong to the drive they came from.
//!
//! A model: no egui here.

use super::Browser;

/// How something went: the colour of its message. Refusals and warnings are never green.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tone {
    /// Done as asked (green).
    Done,
    /// Neither good nor bad news: a preview, a plan (the text colour).
    Info,
    /// Done, but not all of it: refused objects, warnings, a cancel (amber).
    Warning,
    /// Not done (red).
    Failed,
}

/// One message of the browser.
#[derive(Clone, Debug, PartialEq)]
pub struct Message {
    pub tone: Tone,
    pub text: String,
    /// The link it came from ("" when none was connected).
    pub link: String,
    /// The connection it came from ([`Browser::connection`] then).
    pub connection: u64,
}

impl Message {
    /// Said on an earlier connection than `connection` (one to a link: a message said
    /// while none was connected belongs to none).
    pub fn earlier(&self, connection: u64) -> bool {
        !self.link.is_empty() && self.connection != connection
    }
}

impl Browser {
    /// A message about the link connected now.
    pub(super) fn message_now(&self, tone: Tone, text: impl Into<String>) -> Message {
        Message {
            tone,
            text: text.into(),
            link: self.source.text.clone(),
            connection: self.source.connection,
        }
    }

    /// Say how something went.
    pub fn say(&mut self, tone: Tone, text: impl Into<String>) {
        self.message = Some(self.message_now(tone, text));
    }

    /// How many connections the window made so far: what is shown belongs to the last.
    pub fn connection(&self) -> u64 {
        self.source.connection
    }

    /// A new connection, to `link`: what was judged against the drive as it was goes (the
    /// comparison, the restore preview, a write waiting for its confirmation, the edit, a
    /// bulk read), and answers still coming over the old link are dropped. The values stay
    /// when it is the same link as before (the table reads them again by itself, their age
    /// shown), they go with the write results for another one. The message stays, marked
    /// as from the earlier connection.
    pub fn on_connected(&mut self, link: &str) {
        self.source.connection += 1;
        self.source.text = link.to_owned();
        self.comparison = None;
        self.restore = None;
        self.confirm = None;
        self.confirm_store = false;
        self.edit = None;
        self.bulk = None;
        self.refresh.forget_all();
        if self.source.values_of != link {
            self.source.values_of = link.to_owned();
            self.values.clear();
            self.write_results.clear();
        }
    }
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use super::*;
    use crate::od::backup::Backup;
    use crate::od::{Address, Value};
    use crate::ui::browser::{Bulk, Pending, Purpose, Restore};
    use crate::worker::Rejection;

    fn bulk(total: usize, failed: usize) -> Bulk {
        Bulk {
            id: None,
            total,
            done: total,
            failed,
            purpose: Purpose::Browse,
            reads: BTreeMap::new(),
            cancelled: false,
        }
    }

    fn tone(b: &Browser) -> Option<Tone> {
        b.message.as_ref().map(|m| m.tone)
    }

    #[test]
    fn a_read_with_refusals_is_a_warning_never_green() {
        let mut b = Browser::new();
        b.finish_browse(&bulk(10, 0));
        assert_eq!(tone(&b), Some(Tone::Done));
        b.finish_browse(&bulk(10, 3));
        assert_eq!(tone(&b), Some(Tone::Warning));
        let color = super::super::panel::tone_color;
        assert_ne!(color(Tone::Warning), color(Tone::Done));
        assert_ne!(color(Tone::Failed), color(Tone::Done));
    }

    #[test]
    fn a_restore_with_a_refused_write_fails() {
        let mut b = Browser::new();
        b.restore = Some(Restore {
            backup: Box::new(Backup::new(
                "sim",
                crate::od::builtin(),
                &BTreeMap::<Address, Result<Value, String>>::new(),
                0,
            )),
            steps: vec![],
            results: vec![None, None],
            running: true,
            confirm: false,
            skipped: vec![],
            mismatch: None,
            force: false,
        });
        assert!(!b.restore_result(0, Ok(())));
        assert!(b.restore_result(1, Err("refused".into())));
        assert_eq!(tone(&b), Some(Tone::Failed));
    }

    #[test]
    fn a_read_the_user_asked_for_says_its_refusal_the_table_s_own_do_not() {
        let mut b = Browser::new();
        b.on_connected("sim");
        let entry = crate::od::builtin()
            .filter("6081")
            .next()
            .expect("6081h")
            .clone();
        // The table's own read, refused: nothing said (it tries again by itself).
        b.visible = vec![entry.address];
        b.refresh_visible(true, 10.0);
        let (mut own, _) = b.take_asks().pop().expect("a read");
        b.sent(1, &own);
        assert!(!b.on_rejected(1, &mut own, &Rejection::LinkGone("gone".into())));
        assert_eq!(own, Pending::Stale, "its later answers are dropped");
        assert_eq!(b.message, None);
        // A row's Read, refused: said in red.
        b.read_one(entry.address, entry.dtype);
        let (mut asked, _) = b.take_asks().pop().expect("a read");
        b.sent(2, &asked);
        b.on_rejected(2, &mut asked, &Rejection::LinkGone("gone".into()));
        assert_eq!(tone(&b), Some(Tone::Failed));
    }

    #[test]
    fn a_message_belongs_to_the_connection_it_came_from() {
        let mut b = Browser::new();
        b.on_connected("sim");
        b.say(Tone::Info, "3 writes would make the device match the file");
        let said = b.message.clone().expect("said");
        assert!(!said.earlier(b.connection()));
        b.on_connected("sim");
        assert!(
            said.earlier(b.connection()),
            "a reconnect is another connection"
        );
        // Said while no link was up: it belongs to none.
        b.source.text.clear();
        b.say(Tone::Failed, "cannot read x.json");
        let offline = b.message.clone().expect("said");
        b.on_connected("sim");
        assert!(!offline.earlier(b.connection()));
    }
}
