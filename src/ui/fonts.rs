//! The window's fonts: egui's defaults, with the glyphs its proportional font (Ubuntu
//! Light) lacks taken from Hack, the monospace font egui already bundles. Without it
//! "T→O" (EtherNet/IP's directions, in the log and link errors) draws its arrow as an
//! empty box.

use eframe::egui::{self, Color32, FontDefinitions, FontFamily, FontId, TextStyle};

/// Hack's name in egui's default font definitions.
const HACK: &str = "Hack";

/// The size of secondary text (egui's `Small`, 9 points by default: too small to read on
/// a laptop beside a machine).
pub const SMALL_SIZE: f32 = 12.0;
/// Weak (secondary) text on the dark theme: light enough to read (about 8:1 against the
/// panels' background), still quieter than the text beside it.
const WEAK_TEXT: Color32 = Color32::from_gray(168);

/// The window's text styles: secondary text legible.
pub fn style(ctx: &egui::Context) {
    ctx.all_styles_mut(|style| {
        style
            .text_styles
            .insert(TextStyle::Small, FontId::proportional(SMALL_SIZE));
        if style.visuals.dark_mode {
            style.visuals.weak_text_color = Some(WEAK_TEXT);
        }
    });
}

/// egui's default fonts, with Hack as the last fallback of the proportional family.
pub fn definitions() -> FontDefinitions {
    let mut fonts = FontDefinitions::default();
    if fonts.font_data.contains_key(HACK)
        && let Some(family) = fonts.families.get_mut(&FontFamily::Proportional)
        && !family.iter().any(|name| name == HACK)
    {
        family.push(HACK.to_owned());
    }
    fonts
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;
    use std::path::{Path, PathBuf};

    use eframe::egui::{self, FontFamily, FontId};

    /// Every character outside ASCII in the string literals of `text` (comment lines
    /// left out), each with where it was first seen.
    fn literal_chars(text: &str, file: &Path, found: &mut BTreeMap<char, String>) {
        for (n, line) in text.lines().enumerate() {
            let code = line.trim_start();
            if code.starts_with("//") {
                continue;
            }
            let mut inside = false;
            let mut escaped = false;
            for c in code.chars() {
                match c {
                    _ if escaped => escaped = false,
                    '\\' if inside => escaped = true,
                    '"' => inside = !inside,
                    c if inside && !c.is_ascii() => {
                        found
                            .entry(c)
                            .or_insert_with(|| format!("{}:{}", file.display(), n + 1));
                    }
                    _ => {}
                }
            }
        }
    }

    fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for entry in entries.flatten() {
            let path = entry.path();
            if path.is_dir() {
                sources(&path, out);
            } else if path.extension().is_some_and(|e| e == "rs" || e == "json") {
                out.push(path);
            }
        }
    }

    /// Every glyph the code can put on screen (its string literals, and the catalog's
    /// names and units) is in a font of the family it is drawn with.
    #[test]
    fn every_character_of_the_texts_has_a_glyph() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let mut files = Vec::new();
        sources(&root.join("src"), &mut files);
        sources(&root.join("assets/od"), &mut files);
        let mut found = BTreeMap::new();
        for file in &files {
            let text = std::fs::read_to_string(file).unwrap_or_default();
            literal_chars(&text, file.strip_prefix(root).unwrap_or(file), &mut found);
        }
        assert!(
            found.contains_key(&'→'),
            "the scan finds T\u{2192}O (EtherNet/IP's directions)"
        );
        let ctx = egui::Context::default();
        ctx.set_fonts(super::definitions());
        // One frame builds the font atlas; its texture is not uploaded anywhere.
        let mut output = ctx.run_ui(egui::RawInput::default(), |_| {});
        output.textures_delta.clear();
        let missing: Vec<String> = ctx.fonts_mut(|fonts| {
            [FontFamily::Proportional, FontFamily::Monospace]
                .into_iter()
                .flat_map(|family| {
                    let font = FontId::new(14.0, family.clone());
                    found
                        .iter()
                        .filter(|(c, _)| !fonts.has_glyph(&font, **c))
                        .map(|(c, at)| format!("{c:?} (U+{:04X}, {at}) in {family:?}", *c as u32))
                        .collect::<Vec<_>>()
                })
                .collect()
        });
        assert!(missing.is_empty(), "no glyph for {missing:#?}");
    }
}
