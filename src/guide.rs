//! The user guide (`docs/guide/`), built into the binary so that every copy of drivedeck
//! carries the guide of its own version: the pages as HTML, written into a folder with
//! the links between pages kept and the pictures taken from where they are. The window's
//! Guide button (F1) opens them in the browser; `drivedeck install-files` writes them for
//! the package, beside the Markdown and the pictures.

use std::path::{Path, PathBuf};

use pulldown_cmark::{CowStr, Event, Options, Parser, Tag, TagEnd};

/// One page of the guide: its Markdown file's name and text.
pub struct Page {
    pub file: &'static str,
    pub markdown: &'static str,
}

macro_rules! page {
    ($file:literal) => {
        Page {
            file: $file,
            markdown: include_str!(concat!("../docs/guide/", $file)),
        }
    };
}

/// Every page, the index first.
pub const PAGES: &[Page] = &[
    page!("README.md"),
    page!("01-getting-started.md"),
    page!("02-connecting.md"),
    page!("03-window.md"),
    page!("04-plots-and-recordings.md"),
    page!("05-dictionary-backup-restore.md"),
    page!("06-projects.md"),
    page!("07-test-moves-and-tuning.md"),
    page!("08-nanoj-and-io.md"),
    page!("09-procedures-and-records.md"),
    page!("10-command-line.md"),
    page!("11-troubleshooting.md"),
];

/// The index's HTML file.
pub const INDEX: &str = "index.html";

/// Where the package puts the guide (its Markdown, pictures and HTML).
pub const INSTALLED: &str = "/usr/share/doc/drivedeck/guide";

/// The HTML file of a page: `index.html` for the index, else the Markdown name with
/// `.html`.
pub fn html_name(markdown_file: &str) -> String {
    if markdown_file == "README.md" {
        INDEX.to_owned()
    } else {
        format!("{}.html", markdown_file.trim_end_matches(".md"))
    }
}

/// A link target of the Markdown, as the HTML pages have it: another page (`x.md#part`)
/// becomes its `.html`, a picture (`img/…`) is taken from `pictures`; `None` for a
/// target outside the guide (`../protocol-notes.md`: in the source only), whose link is
/// left out and its text kept.
fn target(url: &str, pictures: &str) -> Option<String> {
    if url.contains("://") || url.starts_with('#') || url.starts_with("mailto:") {
        return Some(url.to_owned());
    }
    if url.starts_with("../") {
        return None;
    }
    if let Some(picture) = url.strip_prefix("img/") {
        return Some(format!("{}/{picture}", pictures.trim_end_matches('/')));
    }
    let (file, part) = url
        .split_once('#')
        .map_or((url, None), |(f, p)| (f, Some(p)));
    if file.ends_with(".md") {
        let html = html_name(file);
        return Some(match part {
            Some(part) => format!("{html}#{part}"),
            None => html,
        });
    }
    Some(url.to_owned())
}

/// The text of a heading as an anchor, as GitHub makes them (lower case, spaces to `-`,
/// punctuation dropped), so that `page.md#the-part` links keep working.
fn anchor(text: &str) -> String {
    text.trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

/// One page as a whole HTML document; its pictures from `pictures` (a folder or a URL
/// prefix).
pub fn html(page: &Page, pictures: &str) -> String {
    let options = Options::ENABLE_TABLES | Options::ENABLE_STRIKETHROUGH;
    let mut title = String::new();
    let mut in_heading = false;
    let mut heading_text = String::new();
    // Per open link: whether it was kept (a link out of the guide is dropped, its text kept).
    let mut links: Vec<bool> = vec![];
    let mut events: Vec<Event<'_>> = vec![];
    for event in Parser::new_ext(page.markdown, options) {
        match event {
            Event::Start(Tag::Link {
                link_type,
                dest_url,
                title,
                id,
            }) => match target(&dest_url, pictures) {
                Some(url) => {
                    links.push(true);
                    events.push(Event::Start(Tag::Link {
                        link_type,
                        dest_url: CowStr::from(url),
                        title,
                        id,
                    }));
                }
                None => links.push(false),
            },
            Event::End(TagEnd::Link) => {
                if links.pop().unwrap_or(true) {
                    events.push(Event::End(TagEnd::Link));
                }
            }
            Event::Start(Tag::Image {
                link_type,
                dest_url,
                title,
                id,
            }) => {
                let url = target(&dest_url, pictures).unwrap_or_else(|| dest_url.to_string());
                events.push(Event::Start(Tag::Image {
                    link_type,
                    dest_url: CowStr::from(url),
                    title,
                    id,
                }));
            }
            Event::Start(Tag::Heading {
                level,
                classes,
                attrs,
                ..
            }) => {
                in_heading = true;
                heading_text.clear();
                // The id is set at the end, once the text is known.
                events.push(Event::Start(Tag::Heading {
                    level,
                    id: None,
                    classes,
                    attrs,
                }));
            }
            Event::End(TagEnd::Heading(level)) => {
                in_heading = false;
                if title.is_empty() {
                    title = heading_text.clone();
                }
                // Put the anchor on the heading just opened.
                if let Some(Event::Start(Tag::Heading { id, .. })) = events
                    .iter_mut()
                    .rev()
                    .find(|e| matches!(e, Event::Start(Tag::Heading { .. })))
                {
                    *id = Some(CowStr::from(anchor(&heading_text)));
                }
                events.push(Event::End(TagEnd::Heading(level)));
            }
            Event::Text(text) | Event::Code(text) if in_heading => {
                heading_text.push_str(&text);
                events.push(Event::Text(text));
            }
            other => events.push(other),
        }
    }
    let mut body = String::new();
    pulldown_cmark::html::push_html(&mut body, events.into_iter());
    let escaped = title
        .replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;");
    format!(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\
         <title>{escaped} — drivedeck {version}</title><style>{STYLE}</style></head>\
         <body><nav><a href=\"{INDEX}\">drivedeck guide</a> · version {version}</nav>\n\
         {body}</body></html>\n",
        version = env!("CARGO_PKG_VERSION"),
    )
}

/// Plain and readable, light or dark as the desktop is; no resource loaded.
const STYLE: &str = "body{font-family:system-ui,sans-serif;max-width:60rem;margin:0 auto;\
padding:1rem 1.5rem;line-height:1.5}img{max-width:100%;border:1px solid #8884}\
table{border-collapse:collapse}td,th{border:1px solid #8886;padding:.25rem .5rem;\
vertical-align:top}code,pre{font-family:ui-monospace,monospace;font-size:.92em}\
pre{overflow-x:auto;padding:.5rem;background:#8881}nav{font-size:.9em;margin-bottom:1rem}\
@media (prefers-color-scheme:dark){body{background:#1b1b1b;color:#ddd}a{color:#8cf}}";

/// Write every page as HTML into `dir`, their pictures from `pictures`: the index's path.
pub fn write(dir: &Path, pictures: &str) -> Result<PathBuf, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot make {}: {e}", dir.display()))?;
    for page in PAGES {
        let path = dir.join(html_name(page.file));
        crate::file::write_whole(&path, html(page, pictures).as_bytes())
            .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    }
    Ok(dir.join(INDEX))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn links_between_pages_become_html_and_links_out_of_the_guide_are_dropped() {
        let page = Page {
            file: "x.md",
            markdown: "# The title\n\nSee [the window](03-window.md#small-screens), \
                       [the index](README.md), [notes](../protocol-notes.md) and \
                       [web](https://example.org).\n\n![A picture](img/window.png)\n\n\
                       ## Small screens\n\n| a | b |\n| --- | --- |\n| 1 | 2 |\n",
        };
        let html = html(&page, "/usr/share/doc/drivedeck/guide/img");
        assert!(
            html.contains("href=\"03-window.html#small-screens\""),
            "{html}"
        );
        assert!(html.contains("href=\"index.html\""), "{html}");
        assert!(!html.contains("protocol-notes"), "{html}");
        assert!(html.contains("notes"), "the text stays: {html}");
        assert!(html.contains("href=\"https://example.org\""));
        assert!(html.contains("src=\"/usr/share/doc/drivedeck/guide/img/window.png\""));
        assert!(html.contains("<h2 id=\"small-screens\">"), "{html}");
        assert!(html.contains("<table>"), "tables: {html}");
        assert!(html.contains("<title>The title — drivedeck"), "{html}");
    }

    #[test]
    fn every_page_is_written_and_every_link_between_them_lands_on_a_page_and_an_anchor() {
        let dir = tempfile::tempdir().expect("dir");
        let index = write(dir.path(), "img").expect("written");
        assert_eq!(index, dir.path().join(INDEX));
        let pages: Vec<(String, String)> = PAGES
            .iter()
            .map(|p| {
                let name = html_name(p.file);
                let text = std::fs::read_to_string(dir.path().join(&name)).expect("page");
                (name, text)
            })
            .collect();
        let mut links = 0;
        for (name, text) in &pages {
            for href in text.split("href=\"").skip(1) {
                let href = &href[..href.find('"').unwrap_or(0)];
                if href.contains("://") {
                    continue;
                }
                let (file, part) = href.split_once('#').unwrap_or((href, ""));
                let file = if file.is_empty() { name.as_str() } else { file };
                let target = pages
                    .iter()
                    .find(|(n, _)| n == file)
                    .unwrap_or_else(|| panic!("{name}: a link to {href}, no such page"));
                if !part.is_empty() {
                    assert!(
                        target.1.contains(&format!("id=\"{part}\"")),
                        "{name}: a link to {href}, no such part"
                    );
                }
                links += 1;
            }
        }
        assert!(links > 50, "{links} links");
    }
}
