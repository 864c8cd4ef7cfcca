//! The plots as a PNG: for one frame a title band (the device, the link, the date, the
//! time span) is drawn above the plots, the window's screenshot of that frame is cut to
//! the band and the whole plot area (every axis and its labels) at the screen's full
//! resolution, and the save dialog asks where it goes.

use std::path::Path;
use std::sync::Arc;

use eframe::egui::{self, Rect, RichText, Ui};

use super::exports::Job;
use super::exports_view::ask;
use super::model::{Image, Picture, PlotView, shown_scope, time_range};
use super::view::Plots;

/// Take a picture of the plots in the next frame.
pub fn request(ctx: &egui::Context, view: &mut PlotView) {
    if view.picture.due {
        return;
    }
    view.picture.due = true;
    view.message = Some(Ok("taking a picture of the plots…".into()));
    ctx.request_repaint();
}

/// The title of the picture, drawn above the plots in the frame it is taken: what and
/// whose the plots are, and when.
pub fn title_band_ui(ui: &mut Ui, p: &Plots<'_>) -> Option<Rect> {
    if !p.view.picture.due {
        return None;
    }
    let (title, details) = title_lines(p, std::time::SystemTime::now());
    let response = ui
        .vertical(|ui| {
            ui.label(RichText::new(title).heading().strong());
            ui.label(details);
        })
        .response;
    Some(response.rect)
}

/// The picture's title ("drivedeck plots — PD4-E601L42") and the line under it (the
/// identity, the link, the date, the time span).
pub fn title_lines(p: &Plots<'_>, now: std::time::SystemTime) -> (String, String) {
    let scope = shown_scope(p.view, p.drive);
    let meta = &scope.meta;
    let identity = p
        .drive
        .link
        .identity
        .as_ref()
        .filter(|_| p.view.review.is_none());
    let device = identity
        .and_then(|i| i.name.clone())
        .or_else(|| meta.device_name.clone())
        .unwrap_or_else(|| "no device named".into());
    let title = match &p.view.review {
        Some(review) => format!("drivedeck — {device} — {}", review.base.title),
        None => format!("drivedeck plots — {device}"),
    };
    let hex = |v: Option<u32>| v.map(|v| format!("{v:08X}h"));
    let fields = [
        (
            "vendor",
            identity
                .and_then(|i| hex(i.vendor))
                .or_else(|| meta.vendor.clone()),
        ),
        (
            "product",
            identity
                .and_then(|i| hex(i.product))
                .or_else(|| meta.product.clone()),
        ),
        (
            "revision",
            identity
                .and_then(|i| hex(i.revision))
                .or_else(|| meta.revision.clone()),
        ),
        (
            "serial",
            identity
                .and_then(|i| hex(i.serial))
                .or_else(|| meta.serial.clone()),
        ),
        ("link", meta.link.clone()),
        (
            "recorded",
            meta.started.clone().filter(|_| p.view.review.is_some()),
        ),
    ];
    let mut parts: Vec<String> = fields
        .into_iter()
        .filter_map(|(key, value)| value.map(|v| format!("{key} {v}")))
        .collect();
    parts.push(format!("taken {}", crate::telemetry::utc_text(now)));
    if let Some((from, to)) = time_range(p.view, p.drive, p.settings.window_s) {
        parts.push(format!("t {from:.3} s to {to:.3} s"));
    }
    (title, parts.join(" · "))
}

/// After the plots are drawn in the picture's frame: ask for its screenshot, cut to the
/// title band and the plots.
pub fn taken(ctx: &egui::Context, view: &mut PlotView, band: Option<Rect>, plots: Option<Rect>) {
    if !view.picture.due || view.picture.sent {
        return;
    }
    view.picture.sent = true;
    let area = match (band, plots) {
        (Some(band), Some(plots)) => Some(band.union(plots)),
        (band, plots) => band.or(plots),
    };
    let Some(area) = area else {
        view.picture = Picture::default();
        view.message = Some(Err("no plots to take a picture of".into()));
        return;
    };
    let result = view.picture.result.clone();
    let repaint = ctx.clone();
    let pixels_per_point = ctx.pixels_per_point();
    ctx.send_viewport_cmd(egui::ViewportCommand::Screenshot(
        egui::ScreenshotCallback::new(move |image| {
            let cut = cut(&image, area, pixels_per_point);
            if let Ok(mut slot) = result.lock() {
                *slot = Some(cut);
            }
            repaint.request_repaint();
        }),
    ));
}

/// `area` (in points) of the screenshot, in its pixels.
pub fn cut(image: &egui::ColorImage, area: Rect, pixels_per_point: f32) -> Result<Image, String> {
    let whole = Rect::from_min_size(
        egui::Pos2::ZERO,
        egui::vec2(image.size[0] as f32, image.size[1] as f32) / pixels_per_point,
    );
    // `region` panics outside the picture: clamped into it.
    let area = area.intersect(whole);
    if !area.is_positive() {
        return Err("the plots were not in the window's picture".into());
    }
    let region = image.region(&area, Some(pixels_per_point));
    Ok(Image {
        size: region.size,
        rgba: region.pixels.iter().flat_map(|p| p.to_array()).collect(),
    })
}

/// The picture, once taken: the save dialog asks where it goes.
pub fn poll(ctx: &egui::Context, p: &mut Plots<'_>) {
    let taken = super::files::take(&p.view.picture.result);
    if taken.is_some() {
        p.view.picture.due = false;
        p.view.picture.sent = false;
    }
    match taken {
        Some(Ok(image)) => ask(ctx, p, Job::Png(Arc::new(image))),
        Some(Err(e)) => p.view.message = Some(Err(e)),
        None => {}
    }
}

/// An RGBA PNG of `image` at `path`.
pub fn write_png(image: &Image, path: &str) -> Result<String, String> {
    let [width, height] = image.size;
    let mut png_bytes = Vec::new();
    let mut encoder = png::Encoder::new(&mut png_bytes, width as u32, height as u32);
    encoder.set_color(png::ColorType::Rgba);
    encoder.set_depth(png::BitDepth::Eight);
    encoder
        .write_header()
        .and_then(|mut writer| writer.write_image_data(&image.rgba))
        .map_err(|e| format!("cannot make the picture for {path}: {e}"))?;
    crate::file::write_whole(Path::new(path), &png_bytes)
        .map_err(|e| format!("cannot write {path}: {e}"))?;
    Ok(format!(
        "saved a {width}×{height} picture of the plots to {path}"
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cut_is_the_area_at_full_resolution_clamped_into_the_picture() {
        let image = egui::ColorImage::new([400, 300], vec![egui::Color32::RED; 400 * 300]);
        let area = Rect::from_min_max(egui::pos2(10.0, 20.0), egui::pos2(110.0, 70.0));
        let cut_image = cut(&image, area, 2.0).expect("inside");
        assert_eq!(cut_image.size, [200, 100]);
        let beyond = Rect::from_min_max(egui::pos2(150.0, 100.0), egui::pos2(400.0, 400.0));
        assert_eq!(cut(&image, beyond, 2.0).map(|i| i.size), Ok([100, 100]));
        let outside = Rect::from_min_max(egui::pos2(300.0, 300.0), egui::pos2(400.0, 400.0));
        assert!(cut(&image, outside, 2.0).is_err());
    }

    #[test]
    fn a_png_that_cannot_be_written_names_the_full_path_and_the_reason() {
        let image = Image {
            size: [4, 3],
            rgba: [255, 0, 0, 255].repeat(12),
        };
        let dir = std::env::temp_dir().join(format!("no-such-dir-{}", std::process::id()));
        let path = dir.join("plots.png").to_string_lossy().into_owned();
        let error = write_png(&image, &path).expect_err("no such directory");
        assert_eq!(
            error,
            format!("cannot write {path}: No such file or directory (os error 2)")
        );
        let good = std::env::temp_dir().join(format!("drivedeck-png-{}.png", std::process::id()));
        let text = good.to_string_lossy().into_owned();
        let said = write_png(&image, &text).expect("written");
        assert_eq!(said, format!("saved a 4×3 picture of the plots to {text}"));
        let bytes = std::fs::read(&good).expect("read back");
        assert!(bytes.starts_with(b"\x89PNG"));
        let _ = std::fs::remove_file(&good);
    }
}
