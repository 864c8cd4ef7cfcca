//! What the browser says about the last thing done, in the colour of its outcome, and
//! whose link it is: values, previews and messages belong to the drive they came from.

use super::*;
use eframe::egui::Color32;

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

impl Tone {
    /// The colour of the message; `None`: the text colour.
    pub fn color(self) -> Option<Color32> {
        match self {
            Tone::Done => Some(GREEN),
            Tone::Info => None,
            Tone::Warning => Some(AMBER),
            Tone::Failed => Some(RED),
        }
    }
}

/// One message of the browser.
#[derive(Clone, Debug, PartialEq)]
pub struct Message {
    pub tone: Tone,
    pub text: String,
    /// The link it came from ("" when none was connected).
    pub link: String,
}

impl Browser {
    /// A message about the link connected now.
    pub(super) fn message_now(&self, tone: Tone, text: impl Into<String>) -> Message {
        Message {
            tone,
            text: text.into(),
            link: self.link_text.clone(),
        }
    }

    /// Say how something went.
    pub(super) fn say(&mut self, tone: Tone, text: impl Into<String>) {
        self.message = Some(self.message_now(tone, text));
    }

    /// The link now (`""`: none). Another drive than the one the values came from makes
    /// what was read from that one go: values, write results, the comparison, the restore
    /// preview, a write waiting for its confirmation, the edit; answers still coming from
    /// it are dropped. The message stays, marked with the link it came from.
    pub fn follow_link(&mut self, link: &str) {
        if self.link_text == link {
            return;
        }
        self.link_text = link.to_owned();
        if link.is_empty() || self.drive == link {
            // Disconnected, or back on the same drive.
            return;
        }
        let first = self.drive.is_empty();
        self.drive = link.to_owned();
        if first {
            return;
        }
        self.values.clear();
        self.write_results.clear();
        self.comparison = None;
        self.restore = None;
        self.confirm = None;
        self.confirm_store = false;
        self.edit = None;
        self.bulk = None;
        self.refresh.forget_all();
        for pending in self.ids.values_mut() {
            *pending = Pending::Stale;
        }
    }
}

/// The message line: in its outcome's colour; one from another link than the one now is
/// dimmed and says where it came from.
pub(super) fn message_ui(ui: &mut Ui, b: &Browser) {
    let Some(message) = &b.message else {
        return;
    };
    let earlier = !message.link.is_empty() && message.link != b.link_text;
    let mut text = if earlier {
        RichText::new(format!(
            "[{}, earlier connection] {}",
            message.link, message.text
        ))
    } else {
        RichText::new(&message.text)
    };
    if let Some(color) = message.tone.color() {
        text = text.color(if earlier {
            color.gamma_multiply(0.6)
        } else {
            color
        });
    } else if earlier {
        text = text.weak();
    }
    ui.add(egui::Label::new(text).wrap());
}
