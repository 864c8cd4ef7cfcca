//! Opening a serial port (Modbus RTU lines, slcan CAN adapters): one place that turns the
//! system's refusal into what to do about it — the port in use, not there, or not
//! allowed, with the group the device belongs to and how to join it.

use std::io;

use super::Error;

/// The group that owns the device at `path` (`dialout` on Debian and Ubuntu, `uucp` on
/// Arch), where it can be found.
pub fn device_group(path: &str) -> Option<String> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        let gid = std::fs::metadata(path).ok()?.gid();
        let groups = std::fs::read_to_string("/etc/group").ok()?;
        group_named(&groups, gid)
    }
    #[cfg(not(unix))]
    {
        let _ = path;
        None
    }
}

/// The name of group `gid` in an /etc/group text.
fn group_named(groups: &str, gid: u32) -> Option<String> {
    groups.lines().find_map(|line| {
        let mut fields = line.split(':');
        let name = fields.next()?;
        let id: u32 = fields.nth(1)?.parse().ok()?;
        (id == gid && !name.is_empty()).then(|| name.to_owned())
    })
}

/// What to tell the user when opening `path` is not permitted.
pub fn permission_text(path: &str, group: Option<&str>) -> String {
    match group {
        Some(group) => format!(
            "no permission to open {path}: it belongs to the group {group}; join it with \
             `sudo usermod -aG {group} $USER` and log in again (or reboot) for it to take effect"
        ),
        None => format!(
            "no permission to open {path}: on Linux join the group that owns it (usually \
             dialout: `sudo usermod -aG dialout $USER`) and log in again"
        ),
    }
}

/// The error for a serial port that could not be opened, saying what to do.
pub fn open_error(path: &str, e: tokio_serial::Error) -> Error {
    use tokio_serial::ErrorKind;
    match e.kind {
        ErrorKind::NoDevice => Error::Refused(format!(
            "the serial port {path} is in use by another program (slcand, python-can, ModemManager, another drivedeck?) or was just unplugged ({})",
            e.description
        )),
        ErrorKind::Io(io::ErrorKind::NotFound) => Error::Refused(format!(
            "there is no serial port {path}: is the adapter plugged in? (USB adapters are usually /dev/ttyUSB0 or /dev/ttyACM0 on Linux, COMn on Windows)"
        )),
        ErrorKind::Io(io::ErrorKind::PermissionDenied) => {
            Error::Refused(permission_text(path, device_group(path).as_deref()))
        }
        _ => Error::Io {
            context: format!("opening serial port {path}"),
            source: io::Error::other(e.description),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_devices_group_is_named_with_how_to_join_it() {
        let groups = "root:x:0:\ntty:x:5:\ndialout:x:20:pi\nuucp:x:14:\n";
        assert_eq!(group_named(groups, 20).as_deref(), Some("dialout"));
        assert_eq!(group_named(groups, 14).as_deref(), Some("uucp"));
        assert_eq!(group_named(groups, 99), None);
        let refused = open_error(
            "/dev/ttyUSB0",
            tokio_serial::Error::new(
                tokio_serial::ErrorKind::Io(io::ErrorKind::PermissionDenied),
                "Permission denied",
            ),
        );
        // /dev/ttyUSB0 is not there on a test machine: the usual group is said.
        let text = refused.to_string();
        assert!(
            text.contains("no permission to open /dev/ttyUSB0")
                && text.contains("sudo usermod -aG")
                && text.contains("log in again"),
            "{text}"
        );
        assert_eq!(
            permission_text("/dev/ttyACM0", Some("uucp")),
            "no permission to open /dev/ttyACM0: it belongs to the group uucp; join it with \
             `sudo usermod -aG uucp $USER` and log in again (or reboot) for it to take effect"
        );
    }

    #[cfg(unix)]
    #[test]
    fn a_files_group_is_found_in_etc_group() {
        // /etc/passwd belongs to root's group on every Linux.
        assert_eq!(device_group("/etc/passwd").as_deref(), Some("root"));
        assert_eq!(device_group("/no/such/device"), None);
    }
}
