//! Files the tool writes (recordings, backups, exports, pictures): written whole or not at
//! all, to the file the user named (through a symbolic link to its target, straight into a
//! device or pipe such as `/dev/null`), and a place checked before a long recording starts
//! rather than after it ends. And files the tool reads (projects, backups, EDS files,
//! recordings): only regular files, refused at once otherwise (a pipe would wait for its
//! writer forever, a device never ends), and never more than a limit.

use std::fs::OpenOptions;
#[cfg(unix)]
use std::fs::Permissions;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

/// Where writing `path` really writes. A symbolic link is followed (the link stays, its
/// target gets the text); `Special` is an existing file that is no regular file (a device
/// such as `/dev/null`, a pipe): written into as it is, never replaced.
enum Place {
    /// A regular file, existing or new: replaced whole through a file beside it.
    Regular(PathBuf),
    Special(PathBuf),
}

fn place(path: &Path) -> std::io::Result<Place> {
    match std::fs::metadata(path) {
        Ok(meta) if meta.is_dir() => Err(std::io::Error::new(
            std::io::ErrorKind::IsADirectory,
            "it is a directory; give a file name",
        )),
        Ok(meta) if meta.is_file() => Ok(Place::Regular(std::fs::canonicalize(path)?)),
        Ok(_) => Ok(Place::Special(path.to_path_buf())),
        // A link to a file not there yet: the file goes where the link points.
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => match std::fs::read_link(path) {
            Ok(target) => Ok(Place::Regular(match path.parent() {
                Some(dir) if target.is_relative() => dir.join(target),
                _ => target,
            })),
            Err(_) => Ok(Place::Regular(path.to_path_buf())),
        },
        Err(e) => Err(e),
    }
}

/// The directory a new file at `path` goes into.
fn directory(path: &Path) -> &Path {
    match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir,
        _ => Path::new("."),
    }
}

/// A new, hidden, uniquely named file in the directory of `path`, with the permissions the
/// file there has now (or the usual ones for a new file).
fn beside(path: &Path) -> std::io::Result<tempfile::NamedTempFile> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "recording".into());
    let prefix = format!(".{name}.");
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(".drivedeck-partial");
    match std::fs::metadata(path) {
        Ok(meta) => {
            builder.permissions(meta.permissions());
        }
        Err(_) => new_file_permissions(&mut builder),
    }
    builder
        .tempfile_in(directory(path))
        .map_err(without_partial_name)
}

/// tempfile names its own file in an error ("… at path \"/dir/.run.csv.x1Y2.drivedeck-
/// partial\""): the user never asked for that file, so the error names the cause only (the
/// caller names the file the user asked for).
fn without_partial_name(error: std::io::Error) -> std::io::Error {
    let text = error.to_string();
    match text.rsplit_once(" at path ") {
        Some((cause, _)) => std::io::Error::new(error.kind(), cause.to_owned()),
        None => error,
    }
}

/// A new recording is readable by everyone and writable by its owner, less what the umask
/// takes away, as any new file: not the owner-only mode of a private temporary file.
#[cfg(unix)]
fn new_file_permissions(builder: &mut tempfile::Builder) {
    use std::os::unix::fs::PermissionsExt;
    builder.permissions(Permissions::from_mode(0o644));
}

/// Elsewhere a new file gets the system's default.
#[cfg(not(unix))]
fn new_file_permissions(_: &mut tempfile::Builder) {}

/// Write `bytes` to `path` whole or not at all: into a hidden file beside it, then renamed
/// over it, so that a failure midway (a full disk, a vanished directory) never leaves half
/// a file nor spoils the one that was there. A symbolic link keeps pointing where it did;
/// a device or pipe (`/dev/null`, `/dev/stdout`) is written into, never replaced.
pub fn write_whole(path: &Path, bytes: impl AsRef<[u8]>) -> std::io::Result<()> {
    let bytes = bytes.as_ref();
    match place(path)? {
        Place::Special(path) => {
            let mut file = OpenOptions::new().write(true).open(path)?;
            file.write_all(bytes)?;
            file.flush()
        }
        Place::Regular(path) => {
            let mut partial = beside(&path)?;
            partial.write_all(bytes)?;
            partial.as_file().sync_all()?;
            // On failure the partial file is removed as it drops.
            partial
                .persist(&path)
                .map(drop)
                .map_err(|e| without_partial_name(e.error))
        }
    }
}

/// Whether a file can be written at `path` now, without changing anything there: a
/// directory is no file; an existing device or pipe must not be read-only (it is not
/// opened: a pipe would wait for its reader); otherwise a
/// file must be creatable in the directory the file goes to (the way [`write_whole`]
/// writes it, so an existing file in a directory that takes no new file is found too).
pub fn check_writable(path: &Path) -> std::io::Result<()> {
    match place(path)? {
        Place::Special(path) => {
            if std::fs::metadata(&path)?.permissions().readonly() {
                Err(std::io::Error::new(
                    std::io::ErrorKind::PermissionDenied,
                    "it is read-only",
                ))
            } else {
                Ok(())
            }
        }
        Place::Regular(path) => beside(&path).map(drop),
    }
}

/// Why a file the user gave could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    /// A FIFO, a device, a directory, a socket: refused before it is opened for reading.
    #[error("{path} is {kind}, not a file: give {what}")]
    NotAFile {
        path: String,
        /// `a FIFO (named pipe)`, `a directory`, …
        kind: &'static str,
        /// What the command wants, e.g. `a project file`.
        what: &'static str,
    },
    #[error("{path} is {size} bytes: {what} is at most {limit} bytes")]
    TooLarge {
        path: String,
        size: u64,
        limit: u64,
        what: &'static str,
    },
    #[error("cannot read {path}: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
}

/// What a file that is no regular file is, in words.
fn kind_of(meta: &std::fs::Metadata) -> &'static str {
    let kind = meta.file_type();
    if kind.is_dir() {
        return "a directory";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if kind.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if kind.is_char_device() {
            return "a character device";
        }
        if kind.is_block_device() {
            return "a block device";
        }
        if kind.is_socket() {
            return "a socket";
        }
    }
    "not a regular file"
}

/// Open `path` for reading without waiting: a FIFO without a writer would block `open`.
#[cfg(unix)]
fn open_for_reading(path: &Path) -> std::io::Result<std::fs::File> {
    use std::os::unix::fs::OpenOptionsExt;
    OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_NONBLOCK)
        .open(path)
}

#[cfg(not(unix))]
fn open_for_reading(path: &Path) -> std::io::Result<std::fs::File> {
    OpenOptions::new().read(true).open(path)
}

/// The bytes of the file the user gave as `what` (`a project file`, `a backup file`, …):
/// a regular file (a symbolic link to one included) of at most `limit` bytes. A FIFO, a
/// device, a directory or a socket is refused at once, before anything waits on it; the
/// check is made again on the opened file, so that a file swapped meanwhile is refused
/// too. A file that grows while it is read stops at the limit.
pub fn read_given(path: &Path, limit: u64, what: &'static str) -> Result<Vec<u8>, ReadError> {
    let shown = || path.display().to_string();
    let io = |source| ReadError::Io {
        path: shown(),
        source,
    };
    let not_a_file = |meta: &std::fs::Metadata| ReadError::NotAFile {
        path: shown(),
        kind: kind_of(meta),
        what,
    };
    let meta = std::fs::metadata(path).map_err(io)?;
    if !meta.is_file() {
        return Err(not_a_file(&meta));
    }
    let file = open_for_reading(path).map_err(io)?;
    let meta = file.metadata().map_err(io)?;
    if !meta.is_file() {
        return Err(not_a_file(&meta));
    }
    let too_large = |size| ReadError::TooLarge {
        path: shown(),
        size,
        limit,
        what,
    };
    if meta.len() > limit {
        return Err(too_large(meta.len()));
    }
    let mut bytes = Vec::new();
    // One byte more than allowed tells a file too big from one just big enough.
    file.take(limit.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(io)?;
    if bytes.len() as u64 > limit {
        return Err(too_large(meta.len().max(bytes.len() as u64)));
    }
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(dir)
            .expect("list")
            .filter_map(|e| e.ok())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    #[test]
    fn a_file_is_written_whole_or_not_at_all() {
        let dir = tempfile::tempdir().expect("dir");
        let path = dir.path().join("run.csv");
        std::fs::write(&path, "old").expect("old file");
        write_whole(&path, "new").expect("written");
        assert_eq!(std::fs::read_to_string(&path).expect("read"), "new");
        // Nothing half-written is left beside it.
        assert_eq!(names(dir.path()), ["run.csv"]);
        // A place that is gone: an error, and no stray file anywhere.
        let gone = dir.path().join("gone").join("run.csv");
        let error = write_whole(&gone, "text").expect_err("no such directory");
        assert_eq!(error.kind(), std::io::ErrorKind::NotFound);
        assert_eq!(std::fs::read_to_string(&path).expect("read"), "new");
        assert_eq!(names(dir.path()), ["run.csv"]);
    }

    #[cfg(unix)]
    #[test]
    fn a_symbolic_link_keeps_pointing_at_its_file_which_gets_the_text() {
        let dir = tempfile::tempdir().expect("dir");
        let data = dir.path().join("data");
        std::fs::create_dir(&data).expect("dir");
        let target = data.join("run.csv");
        std::fs::write(&target, "old").expect("old");
        let link = dir.path().join("run.csv");
        std::os::unix::fs::symlink(&target, &link).expect("link");
        write_whole(&link, "new").expect("written");
        assert!(
            std::fs::symlink_metadata(&link)
                .expect("meta")
                .file_type()
                .is_symlink(),
            "the link was replaced by a file"
        );
        assert_eq!(std::fs::read_to_string(&target).expect("read"), "new");
        assert_eq!(names(&data), ["run.csv"]);
        // A link whose file is not there yet: the file appears where it points.
        let dangling = dir.path().join("next.csv");
        std::os::unix::fs::symlink("data/next.csv", &dangling).expect("link");
        write_whole(&dangling, "first").expect("written");
        assert_eq!(
            std::fs::read_to_string(data.join("next.csv")).expect("read"),
            "first"
        );
    }

    #[cfg(unix)]
    #[test]
    fn a_pipe_is_written_into_not_replaced() {
        use std::os::unix::fs::FileTypeExt;
        let dir = tempfile::tempdir().expect("dir");
        let fifo = dir.path().join("fifo");
        let made = std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .expect("mkfifo runs");
        assert!(made.success());
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || std::fs::read_to_string(fifo).expect("read the pipe"))
        };
        check_writable(&fifo).expect("a pipe takes a recording");
        write_whole(&fifo, "through the pipe").expect("written");
        assert_eq!(reader.join().expect("reader"), "through the pipe");
        assert!(
            std::fs::symlink_metadata(&fifo)
                .expect("meta")
                .file_type()
                .is_fifo(),
            "the pipe was replaced by a regular file"
        );
    }

    #[cfg(unix)]
    #[test]
    fn a_new_file_gets_the_usual_permissions_and_an_old_one_keeps_its_own() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().expect("dir");
        let new = dir.path().join("new.csv");
        write_whole(&new, "x").expect("written");
        let mode = std::fs::metadata(&new).expect("meta").permissions().mode() & 0o777;
        // 0644 less the umask: never the 0600 of a private temporary file.
        assert_eq!(mode & 0o700, 0o600);
        assert_ne!(mode, 0o600, "a recording is readable by others as usual");
        let old = dir.path().join("old.csv");
        std::fs::write(&old, "x").expect("old");
        std::fs::set_permissions(&old, Permissions::from_mode(0o640)).expect("chmod");
        write_whole(&old, "y").expect("written");
        let mode = std::fs::metadata(&old).expect("meta").permissions().mode() & 0o777;
        assert_eq!(mode, 0o640);
    }

    #[test]
    fn the_check_changes_nothing_and_finds_a_place_that_takes_no_file() {
        let dir = tempfile::tempdir().expect("dir");
        let path = dir.path().join("run.csv");
        check_writable(&path).expect("a new file can go there");
        assert!(names(dir.path()).is_empty(), "the check left a file");
        std::fs::write(&path, "kept").expect("file");
        check_writable(&path).expect("an existing file can be replaced");
        assert_eq!(std::fs::read_to_string(&path).expect("read"), "kept");
        assert_eq!(names(dir.path()), ["run.csv"]);
        let error = check_writable(dir.path()).expect_err("a directory");
        assert!(error.to_string().contains("directory"), "{error}");
        let gone = dir.path().join("gone").join("run.csv");
        assert!(check_writable(&gone).is_err());
        // A file where a directory should be.
        let under_a_file = path.join("run.csv");
        assert!(check_writable(&under_a_file).is_err());
    }

    #[cfg(unix)]
    #[test]
    fn a_fifo_given_to_read_is_refused_at_once() {
        let dir = tempfile::tempdir().expect("dir");
        let fifo = dir.path().join("x");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if !made.is_ok_and(|s| s.success()) {
            eprintln!("SKIPPED LOUDLY: mkfifo is not available, the FIFO case is not tested");
            return;
        }
        let error = read_given(&fifo, 1000, "a project file").expect_err("a FIFO");
        assert_eq!(
            error.to_string(),
            format!(
                "{} is a FIFO (named pipe), not a file: give a project file",
                fifo.display()
            )
        );
        let error = read_given(dir.path(), 1000, "an EDS file").expect_err("a directory");
        assert!(
            error
                .to_string()
                .contains("is a directory, not a file: give an EDS file")
        );
        let error = read_given(Path::new("/dev/zero"), 1000, "a recording").expect_err("a device");
        assert!(
            error
                .to_string()
                .contains("is a character device, not a file"),
            "{error}"
        );
    }

    #[test]
    fn a_given_file_is_read_up_to_its_limit() {
        let dir = tempfile::tempdir().expect("dir");
        let path = dir.path().join("p.json");
        std::fs::write(&path, "0123456789").expect("file");
        assert_eq!(
            read_given(&path, 10, "a project file").expect("read"),
            b"0123456789"
        );
        let error = read_given(&path, 9, "a project file").expect_err("too large");
        assert!(
            matches!(
                error,
                ReadError::TooLarge {
                    size: 10,
                    limit: 9,
                    ..
                }
            ),
            "{error}"
        );
        let error = read_given(&dir.path().join("gone"), 9, "a project file").expect_err("gone");
        assert!(matches!(error, ReadError::Io { .. }), "{error}");
    }
}
