//! Opening the window: on a project, a link, or what was open last time (the two-drive
//! demo on the simulator the first time).

use eframe::egui;

use super::app::{self, App};
use super::connection_form::{Bus, ConnectionForm};
use super::settings::Settings;
use super::{fonts, pace, timings};
use crate::worker;

/// What the window opens on: a project (its file, and the drive to show first), or a
/// link (`--link`), or what was open last time.
pub enum Opening {
    /// The last project when one was opened before and still opens, else the link of the
    /// saved settings (the simulator the first time: the two-drive demo).
    Last,
    /// This link, as one drive.
    Link(crate::link::LinkSpec),
    /// This project, with the drive named shown first.
    Project {
        project: crate::project::Project,
        path: std::path::PathBuf,
        show: Option<String>,
    },
}

/// The application id desktops group the window by (`assets/drivedeck.desktop`).
pub const APP_ID: &str = "drivedeck";

/// The window's icon: `assets/icons/drivedeck-256.png`, built in.
pub fn icon() -> egui::IconData {
    const PNG: &[u8] = include_bytes!("../../assets/icons/drivedeck-256.png");
    decode_icon(PNG).unwrap_or_default()
}

/// RGBA pixels of a PNG (8-bit RGBA, as the shipped icons are).
fn decode_icon(bytes: &[u8]) -> Option<egui::IconData> {
    let mut decoder = png::Decoder::new(std::io::Cursor::new(bytes));
    decoder.set_transformations(png::Transformations::EXPAND | png::Transformations::ALPHA);
    let mut reader = decoder.read_info().ok()?;
    let mut rgba = vec![0; reader.output_buffer_size()?];
    let info = reader.next_frame(&mut rgba).ok()?;
    rgba.truncate(info.buffer_size());
    (info.color_type == png::ColorType::Rgba && info.bit_depth == png::BitDepth::Eight).then_some(
        egui::IconData {
            rgba,
            width: info.width,
            height: info.height,
        },
    )
}

/// Open the window. Blocks until it is closed.
pub fn run_window(opening: Opening) -> Result<(), eframe::Error> {
    let options = eframe::NativeOptions {
        // The first time, the whole screen: eframe clamps the size to the monitor, and a
        // window manager maximises it. Later, the size and place it had (eframe keeps
        // them with the settings).
        viewport: egui::ViewportBuilder::default()
            .with_title("drivedeck")
            // The desktop entry's name (StartupWMClass, the Wayland app id): the window is
            // grouped with its launcher and shows its icon.
            .with_app_id(APP_ID)
            .with_icon(icon())
            .with_inner_size([7680.0, 4320.0])
            .with_maximized(true)
            .with_min_inner_size([900.0, 560.0]),
        ..Default::default()
    };
    eframe::run_native(
        "drivedeck",
        options,
        Box::new(move |cc| {
            let saved: Option<Settings> = cc
                .storage
                .and_then(|s| eframe::get_value(s, app::SETTINGS_KEY));
            let first_start = saved.is_none();
            let mut settings = saved.unwrap_or_default();
            // The workers' news wakes the window at the redraw rate, not at every burst.
            let pace = pace::Pace::new(cc.egui_ctx.clone());
            let notify: worker::Notify = pace.notify();
            let (opening, note) = match opening {
                Opening::Last => last_project(),
                other => (other, None),
            };
            let mut app = match opening {
                Opening::Project {
                    project,
                    path,
                    show,
                } => App::with_project(settings, notify, &project, Some(path), show.as_deref()),
                Opening::Link(spec) => {
                    settings.connection = ConnectionForm::from_spec(&spec, settings.connection);
                    App::new(settings, notify, true)
                }
                Opening::Last => {
                    let demo = settings.connection.bus == Bus::Sim;
                    let mut app = App::new(settings, notify, true);
                    if demo {
                        // The demo: two simulated drives, so the list shows what it is for.
                        let named = app.rename(0, "X axis".into());
                        let added = app.add_drive("Y axis".into(), "sim://");
                        // Drawn beside X axis in the plots, as a machine's axes are compared.
                        if let Ok(index) = &added
                            && let Some(y) = app.drive_mut(*index)
                        {
                            y.in_plots = true;
                        }
                        if let Err(e) = named.and(added.map(|_| ())) {
                            app.shown_mut()
                                .info(format!("the demo's second drive: {e}"));
                        }
                    }
                    app
                }
            };
            if let Some(note) = note {
                app.shown_mut().info(note);
            }
            if first_start {
                app.first_start();
            }
            // Installed before the first frame, so that it is not laid out twice.
            cc.egui_ctx.set_fonts(fonts::definitions());
            fonts::style(&cc.egui_ctx);
            app.started_in_window(timings::Timings::from_env(), pace);
            Ok(Box::new(app))
        }),
    )
}

/// The last project opened, when there is one and it still opens; else what to say.
fn last_project() -> (Opening, Option<String>) {
    last_project_from(crate::project::recent::settings_dir().as_deref())
}

/// [`last_project`] with the settings folder `dir`.
fn last_project_from(dir: Option<&std::path::Path>) -> (Opening, Option<String>) {
    let Some(path) = dir.and_then(crate::project::recent::last_project_in) else {
        return (Opening::Last, None);
    };
    match crate::project::open(&path) {
        Ok(project) => (
            Opening::Project {
                project,
                path,
                show: None,
            },
            None,
        ),
        Err(e) => (
            Opening::Last,
            Some(format!(
                "the last project, {}, did not reopen: {e}",
                path.display()
            )),
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_last_project_reopens_and_one_that_no_longer_opens_is_said() {
        let dir = tempfile::tempdir().expect("a folder");
        assert!(matches!(
            last_project_from(Some(dir.path())),
            (Opening::Last, None)
        ));
        assert!(matches!(last_project_from(None), (Opening::Last, None)));
        let file = dir.path().join("machine.json");
        let drive = crate::project::Drive::new("X axis", crate::link::LinkSpec::Sim);
        let project = crate::project::Project::new(vec![drive]).expect("a project");
        crate::project::save(&project, &file).expect("saved");
        crate::project::recent::remember_in(dir.path(), &file).expect("remembered");
        match last_project_from(Some(dir.path())) {
            (
                Opening::Project {
                    project: opened, ..
                },
                None,
            ) => assert_eq!(opened, project),
            _ => panic!("the last project did not reopen"),
        }
        std::fs::write(&file, "{ not a project").expect("spoilt");
        match last_project_from(Some(dir.path())) {
            (Opening::Last, Some(note)) => {
                assert!(
                    note.contains("did not reopen") && note.contains("machine.json"),
                    "{note}"
                )
            }
            _ => panic!("a spoilt last project must be said"),
        }
    }
}

#[cfg(test)]
mod icon_tests {
    #[test]
    fn the_built_in_icon_decodes_to_its_256_pixels() {
        let icon = super::icon();
        assert_eq!((icon.width, icon.height), (256, 256));
        assert_eq!(icon.rgba.len(), 256 * 256 * 4);
        // Transparent corners, an opaque middle.
        assert_eq!(icon.rgba[3], 0);
        let middle = (128 * 256 + 128) * 4;
        assert_eq!(icon.rgba[middle + 3], 255);
    }
}
