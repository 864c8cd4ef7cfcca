//! The guide from the window (the "?" button, F1): the installed HTML pages where the
//! package put them, else the pages built into this binary written into the cache folder
//! (their pictures from the package's folder, or from the source tree this binary was
//! built from), opened in the browser.

use std::path::{Path, PathBuf};

use crate::guide;

/// The folder the built-in pages are written into: the user's cache, per version.
fn cache_folder() -> PathBuf {
    let cache = std::env::var_os("XDG_CACHE_HOME")
        .map(PathBuf::from)
        .filter(|p| p.is_absolute())
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache")))
        .unwrap_or_else(std::env::temp_dir);
    cache
        .join("drivedeck")
        .join(format!("guide-{}", env!("CARGO_PKG_VERSION")))
}

/// Where the pictures are: the package's, else the source tree's this binary was built
/// from, else none (the pages say what each picture shows).
fn pictures() -> String {
    let installed = Path::new(guide::INSTALLED).join("img");
    let source = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/guide/img");
    [installed, source]
        .into_iter()
        .find(|p| p.is_dir())
        .map_or_else(|| "img".to_owned(), |p| p.display().to_string())
}

/// The guide's index page, written first where it is not installed.
pub fn index() -> Result<PathBuf, String> {
    let installed = Path::new(guide::INSTALLED).join(guide::INDEX);
    if installed.is_file() {
        return Ok(installed);
    }
    guide::write(&cache_folder(), &pictures())
}

/// Open the guide in the browser: what the log says of it.
pub fn open() -> Result<PathBuf, String> {
    let index = index()?;
    super::plots::files::open_with_system(&index)?;
    Ok(index)
}
