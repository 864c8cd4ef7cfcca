//! The plots as a PNG: for one frame a title band (the device, the link, the date, the
//! time span) is drawn above the plots, the window's screenshot of that frame is cut to
//! the band and the whole plot area (every axis and its labels) at the screen's full
//! resolution (or up to twice it: for those frames the window's zoom is raised and the
//! band and plots are drawn alone in the window at their size on screen, so they come out
//! with the same layout and more pixels), and the save dialog asks where it goes.

use std::path::Path;
use std::sync::Arc;

use eframe::egui::{self, Rect, RichText, Ui};

use super::exports::Job;
use super::exports_view::ask;
use super::model::{Enlarged, Image, Picture, PlotView, shown_scope, time_range};
use super::view::Plots;

/// Frames a picture may take to come before it is given up (and the window's zoom put
/// back).
const PICTURE_FRAMES_MAX: u32 = 120;
/// The room kept around the plots drawn alone, in points: the window's own margin, if
/// any, and a little for rounding.
const PANEL_MARGIN: f32 = 10.0;
/// A picture is taken larger only when it comes out at least this many times larger.
const ENLARGED_MIN: f32 = 1.1;

/// Take a picture of the plots in the next frames, at up to `scale` times the screen's
/// resolution (1 or 2): the title band and the plots are drawn alone in the window, laid
/// out in the room they had on screen, as many times larger as the window holds them.
pub fn request(ui: &Ui, p: &mut Plots<'_>) {
    let ctx = ui.ctx();
    let scale = p.settings.picture_scale;
    let band = p
        .view
        .drawn_at
        .room
        .map(|[width, _]| band_height(ui, p, width));
    let view = &mut *p.view;
    if view.picture.due {
        return;
    }
    let asked = if scale >= 2.0 { 2.0 } else { 1.0 };
    view.picture.due = true;
    view.picture.frames = 0;
    view.picture.scale = 1.0;
    view.message = Some(Ok("taking a picture of the plots…".into()));
    // No plots drawn yet: the band alone says there is nothing to take.
    let (Some([width, height]), Some(band)) = (view.drawn_at.room, band) else {
        ctx.request_repaint();
        return;
    };
    // Laid out as on screen, the title band above them.
    let size = [width, height + band];
    let fits = enlarged_scale(size, ctx.content_rect().size().into(), asked);
    let most = if fits >= ENLARGED_MIN { fits } else { 1.0 };
    let zoom = ctx.zoom_factor();
    view.picture.scale = most;
    view.picture.enlarged = Some(Enlarged {
        zoom_before: zoom,
        size,
        band,
    });
    if most > 1.0 {
        ctx.set_zoom_factor(zoom * most);
        let short = if most < asked - 0.05 {
            format!(" (the most this window holds; {asked:.0}× needs a larger window)")
        } else {
            String::new()
        };
        // The picture is cut to the band and the plots' axes, within that room.
        let [left, top, right, bottom] = view.drawn_at.area.unwrap_or([0.0, 0.0, width, height]);
        let pixels = ctx.pixels_per_point() * most;
        view.message = Some(Ok(format!(
            "taking a {most:.1}× picture of the plots, about {:.0}×{:.0} px{short}…",
            (right - left) * pixels,
            (bottom - top + band) * pixels
        )));
    } else if asked > 1.0 {
        view.message = Some(Ok(format!(
            "taking a picture of the plots at the screen's resolution: the window has no room \
             to draw them {asked:.0}× larger (make the window larger or the plots smaller)…"
        )));
    }
    ctx.request_repaint();
}

/// How many times larger the title and plots (`size`, in points) can be drawn, at most
/// `most`: at their size in points, in the whole window (`screen`, in points now, less
/// the panel's margins) once its zoom is raised by that factor.
pub fn enlarged_scale(size: [f32; 2], screen: [f32; 2], most: f32) -> f32 {
    // The margins are in points too: zoomed with the plots.
    let room = |screen: f32, size: f32| screen / (size + 2.0 * PANEL_MARGIN).max(1.0);
    most.min(room(screen[0], size[0]))
        .min(room(screen[1], size[1]))
}

/// The picture being taken at a higher resolution, once the window's zoom is raised for
/// it (the frame after it was asked for).
pub fn enlarged(ctx: &egui::Context, view: &PlotView) -> Option<Enlarged> {
    let enlarged = view.picture.enlarged.filter(|_| view.picture.due)?;
    (ctx.zoom_factor() >= enlarged.zoom_before * view.picture.scale - 1e-3).then_some(enlarged)
}

/// The title band and the plots alone in `ui` (the whole window while the picture is
/// taken) for a picture at a higher resolution, at most their size on screen: where each
/// was.
pub fn enlarged_ui(
    ui: &mut Ui,
    p: &mut Plots<'_>,
    enlarged: Enlarged,
) -> (Option<Rect>, Option<Rect>) {
    let size = egui::vec2(enlarged.size[0], enlarged.size[1]).min(ui.available_size());
    ui.allocate_ui_with_layout(size, egui::Layout::top_down(egui::Align::Min), |ui| {
        ui.set_min_size(size);
        ui.set_max_size(size);
        let band = title_band_ui(ui, p);
        // The plots in the room they had on screen (the band may take less than its share).
        let room = egui::vec2(size.x, size.y - enlarged.band).min(ui.available_size());
        let plots = ui
            .allocate_ui_with_layout(room, egui::Layout::top_down(egui::Align::Min), |ui| {
                ui.set_max_size(room);
                super::traces::traces_ui(ui, p)
            })
            .inner;
        (band, plots)
    })
    .inner
}

/// The picture is done (taken, failed or given up): the window's zoom as it was.
fn finish(ctx: &egui::Context, view: &mut PlotView) {
    if let Some(enlarged) = view.picture.enlarged.take() {
        ctx.set_zoom_factor(enlarged.zoom_before);
    }
    view.picture = Picture::default();
}

/// The title of the picture, drawn above the plots in the frame it is taken: what and
/// whose the plots are, and when.
pub fn title_band_ui(ui: &mut Ui, p: &Plots<'_>) -> Option<Rect> {
    if !p.view.picture.due {
        return None;
    }
    let [title, details] = band_texts(p);
    let response = ui
        .vertical(|ui| {
            ui.label(title);
            ui.label(details);
        })
        .response;
    Some(response.rect)
}

/// The title band's two texts, as drawn.
fn band_texts(p: &Plots<'_>) -> [RichText; 2] {
    let (title, details) = title_lines(p, std::time::SystemTime::now());
    [
        RichText::new(title).heading().strong(),
        RichText::new(details),
    ]
}

/// The height in points the title band takes at `width` (its lines wrap in a narrow one).
fn band_height(ui: &Ui, p: &Plots<'_>, width: f32) -> f32 {
    let spacing = ui.spacing().item_spacing.y;
    band_texts(p)
        .into_iter()
        .map(|text| {
            egui::WidgetText::from(text)
                .into_galley(
                    ui,
                    Some(egui::TextWrapMode::Wrap),
                    width,
                    egui::TextStyle::Body,
                )
                .size()
                .y
                + spacing
        })
        .sum()
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
pub fn taken(
    ctx: &egui::Context,
    view: &mut PlotView,
    band: Option<Rect>,
    plots: Option<Rect>,
    alone: bool,
) {
    if !view.picture.due {
        return;
    }
    view.picture.frames += 1;
    if view.picture.frames > PICTURE_FRAMES_MAX {
        finish(ctx, view);
        view.message = Some(Err("no picture came from the window; try again".into()));
        return;
    }
    // The picture waits for a frame with the plots drawn alone (at the raised zoom).
    let waiting = view.picture.enlarged.is_some() && !alone;
    if view.picture.sent || waiting {
        return;
    }
    view.picture.sent = true;
    let area = match (band, plots) {
        (Some(band), Some(plots)) => Some(band.union(plots)),
        (band, plots) => band.or(plots),
    };
    let Some(area) = area else {
        finish(ctx, view);
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
        finish(ctx, p.view);
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
    fn a_larger_picture_is_as_large_as_the_window_holds_the_plots_at_their_size() {
        // 657×405 points of plots and band (and the margins) on a 1366×768 window: 768
        // points high take them 1.81× larger, not 2× (the layout would have to change).
        let scale = enlarged_scale([657.0, 405.0], [1366.0, 768.0], 2.0);
        assert!((scale - 768.0 / 425.0).abs() < 1e-4, "{scale}");
        // On 1920×1080 there is room for twice.
        assert_eq!(enlarged_scale([600.0, 300.0], [1920.0, 1080.0], 2.0), 2.0);
        // Plots filling a window: no room at all (taken at the screen's resolution).
        assert!(enlarged_scale([1000.0, 700.0], [1024.0, 600.0], 2.0) < ENLARGED_MIN);
        // Cut from a screenshot at 2 pixels a point: twice as many pixels each way.
        let image = egui::ColorImage::new([1366, 768], vec![egui::Color32::RED; 1366 * 768]);
        let area = Rect::from_min_size(egui::Pos2::ZERO, egui::vec2(600.0, 300.0));
        assert_eq!(cut(&image, area, 2.0).map(|i| i.size), Ok([1200, 600]));
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
