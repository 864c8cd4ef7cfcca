//! The command line: `drivedeck` opens the window (`drivedeck PROJECT.json` on a project);
//! `drivedeck --link URL COMMAND` runs one action and exits, as does
//! `drivedeck --project FILE --drive NAME COMMAND` on a project's drive;
//! `drivedeck --project FILE status` and `od dump DIR` cover every drive of the project;
//! `drivedeck sim …` serves the simulated drive on real sockets.

/// `println!` that does not panic when stdout is a closed pipe (`drivedeck … | head`):
/// what the reader no longer takes is dropped.
macro_rules! outln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($arg)*);
    }};
}

mod bench;
mod bench_io;
mod bench_start;
mod commission;
mod context;
mod failure;
mod gains;
mod install_files;
mod interrupt;
mod io;
mod nanoj;
mod od;
mod oneshot;
mod progress;
mod project_cmd;
mod record;
mod report;
mod serve;
mod session;
mod spectrum;
mod stop;
mod storage;
mod test_move;
mod verify;

use std::process::ExitCode;
use std::time::Duration;

use clap::parser::ValueSource;
use clap::{Args, CommandFactory, FromArgMatches, Parser, Subcommand, ValueEnum};

use context::{Context, Policy};

use crate::link::{LinkSpec, spec::FORMS};
use crate::od::{Address, DataType};

/// Exit codes: 0 success, 1 the drive refused or a command failed, 2 bad usage or no link,
/// 130 interrupted (Ctrl-C, SIGTERM, SIGHUP; 128 + SIGINT's number, as shells do).
pub const EXIT_FAILED: u8 = 1;
pub const EXIT_USAGE: u8 = 2;
pub const EXIT_INTERRUPTED: u8 = 130;

#[derive(Parser, Debug)]
#[command(
    name = "drivedeck",
    version,
    about = "Commissioning tool for Nanotec motor controllers",
    long_about = "Without a command, opens the window (on the simulated drive unless --link or the saved settings say otherwise; `drivedeck PROJECT.json` opens a project). With a command, runs that one action against --link (or --project FILE --drive NAME) and exits: 0 on success, 1 when the drive refuses or the command fails, 2 for bad usage or no link. `--project FILE status` and `--project FILE od dump DIR` cover every drive of the project: 1 when any drive failed.",
    after_help = format!("Connection strings: {FORMS}")
)]
pub struct Cli {
    /// The drive to talk to, e.g. `sim` or `modbus-tcp://192.168.2.100:502`.
    #[arg(long, global = true, value_name = "URL")]
    pub link: Option<LinkSpec>,

    /// A project file (`drivedeck project new`): its drives instead of --link, by name
    /// with --drive; `status` and `od dump DIR` without --drive cover every drive.
    #[arg(long, global = true, value_name = "FILE.json", conflicts_with = "link")]
    pub project: Option<std::path::PathBuf>,

    /// The project's drive a command talks to, by its name, e.g. --drive "X axis".
    #[arg(long, global = true, value_name = "NAME", requires = "project")]
    pub drive: Option<String>,

    /// Open the window on this project (`drivedeck machine.json`).
    #[arg(value_name = "PROJECT.json", value_parser = project_path)]
    pub open: Option<std::path::PathBuf>,

    /// Print JSON instead of text.
    #[arg(long, global = true)]
    pub json: bool,

    /// Print every bus frame sent and received to stderr, decoded.
    #[arg(long, global = true)]
    pub trace: bool,

    /// How long to wait for the drive, in seconds (acknowledgement, and completion with --wait).
    #[arg(long, global = true, default_value_t = 30.0, value_name = "SECONDS", value_parser = parse_timeout, allow_negative_numbers = true)]
    pub timeout: f64,

    /// What a command that moves the motor (or records) leaves the drive in when it is
    /// interrupted (Ctrl-C, SIGTERM, SIGHUP), when its --wait times out, or when the link
    /// fails during the move: halt (brake on the ramp, stay energised), switch-off (power
    /// stage off, the motor coasts) or leave (the drive carries on).
    #[arg(long, global = true, value_enum, default_value_t = OnExit::Halt)]
    pub on_exit: OnExit,

    /// Exchanges that must fail in a row before the link counts as lost (1 to 100); one
    /// lost or corrupted reply is sent again and named, not a lost link.
    #[arg(long, global = true, default_value_t = crate::worker::LOST_AFTER, value_name = "N",
          value_parser = clap::value_parser!(u32).range(1..=100))]
    pub lost_after: u32,

    #[command(subcommand)]
    pub command: Option<Command>,
}

#[derive(Subcommand, Debug, Clone)]
pub enum Command {
    /// Print the drive's status: PDI bits, 603Fh, ReturnValue, CiA 402 state, actual values.
    Status,
    /// Read an object, e.g. `read 1018:01`.
    Read(ReadArgs),
    /// Write an object, e.g. `write 203B:01 1000`.
    Write(WriteArgs),
    /// Profile Position absolute (PDI-Cmd 20) to POS (0.1°) at --speed (rpm).
    MoveAbs(MoveArgs),
    /// Profile Position relative (PDI-Cmd 21) by DELTA (0.1°) at --speed (rpm).
    MoveRel(MoveArgs),
    /// Profile Velocity (PDI-Cmd 23) at V rpm.
    Velocity(VelocityArgs),
    /// Profile Torque (PDI-Cmd 25) at T ‰ of rated torque, limited to --max-speed rpm.
    Torque(TorqueArgs),
    /// Switch the power stage on without moving the motor: Profile Velocity (PDI-Cmd 23)
    /// at 0 rpm (PDI spec §2.2.2), so the motor holds where it stands. Refused while the
    /// motor turns.
    Enable,
    /// Set the halt bit on the drive's travel command.
    Halt(WaitArg),
    /// Reset the halt bit: continue to the old target.
    Resume(WaitArg),
    /// Quickstop (PDI-Cmd 3), with the reaction of 605Ah.
    Quickstop,
    /// Switch Off (PDI-Cmd 1): power stage off.
    SwitchOff,
    /// Clear Error (PDI-Cmd 2): clears a fault once its cause is gone.
    ClearError,
    /// Homing (PDI-Cmd 18) with --method.
    Home(HomeArgs),
    /// Homing on current position (PDI-Cmd 17): the actual position becomes POS.
    HomeHere(HomeHereArgs),
    /// Auto setup (PDI-Cmd 16).
    AutoSetup(WaitArg),
    /// Find the devices on the --link bus: CANopen nodes (node id, vendor, product,
    /// revision, name), or EtherNet/IP adapters (ListIdentity to the host and by broadcast).
    Scan,
    /// Find EtherNet/IP adapters by ListIdentity broadcast (no --link needed).
    Discover(DiscoverArgs),
    /// Serve the simulated drive on real sockets for any client (PLCs, pymodbus, …); give
    /// --node, --slave, --modbus-tcp or --enip again for more drives.
    Sim(SimArgs),
    /// Record signals to CSV or JSON: `record --signals position,velocity --rate 500
    /// --duration 5s --out run.csv`, optionally around a trigger.
    Record(RecordArgs),
    /// A test move with figures: back and forth between --from and --to at --speed, a
    /// --dwell at each end, --cycles times; per step the rise time (10–90 %), overshoot,
    /// settling time into --band, steady-state error, peak/RMS following error and the
    /// time to TargetReached, then their mean and worst.
    TestMove(TestMoveArgs),
    /// Velocity steps with figures: 0 → --speed → −speed → 0 rpm, --hold at each, --cycles
    /// times; per step the figures of the velocity's response, then their mean and worst.
    TestVelocity(TestVelocityArgs),
    /// The digital inputs by name (with their special function and inversion), the
    /// digital outputs and the analog input.
    Io,
    /// Force a digital output on or off, held until --hold ends or Ctrl-C and released
    /// then; `release` gives it back to the drive.
    Output(io::OutputArgs),
    /// The drive's NanoJ program: `nanoj status`, `nanoj start` (waits until it runs or
    /// says its error), `nanoj stop`.
    Nanoj(nanoj::NanojArgs),
    /// Run a commissioning procedure (TOML) on --link or on a project's drives and write
    /// its record (HTML and JSON): `commission axis.toml --project machine.json --record
    /// out.html`; --rehearse runs it against simulated drives first. Exit 0 all passed,
    /// 1 any failed, 130 interrupted.
    Commission(commission::CommissionArgs),
    /// Check a commissioning record's seal: `verify record.json` (or the .html beside it).
    /// Exit 0 the record is as it was written, 1 it was changed after, 2 no record.
    Verify(verify::VerifyArgs),
    /// Write the man pages and shell completions (bash, zsh, fish) into DIR, for a package.
    #[command(hide = true)]
    InstallFiles { dir: std::path::PathBuf },
    /// Store every value as it is now for the next power-on ("save" to 1010h:01).
    Store,
    /// Bring the factory values back at the next restart ("load" to 1011h:01); --reboot
    /// restarts at once.
    Defaults(storage::DefaultsArgs),
    /// Restart the drive's firmware ("boot" to 2800h:01) and wait until it answers again.
    Reboot,
    /// The amplitude spectrum of one signal of a recording (or of the span --from..--to),
    /// with its strongest peaks: `spectrum run.csv --signal velocity`.
    Spectrum(spectrum::SpectrumArgs),
    /// The closed-loop controller's gains (3210h, and 321Ah–321Ch of the newer parameter
    /// set) and the limits that shape a response (max current, speed, ramps, windows):
    /// address, name, value, unit, factory value.
    Gains,
    /// Measure PDI exchanges and object reads per second on --link (or --serve-sim).
    Bench(BenchArgs),
    /// The object dictionary: `od list` shows the built-in catalog or an EDS, with the
    /// values read from the drive when --link is given.
    Od(OdArgs),
    /// Projects: `project new FILE "X axis=modbus-tcp://…" …` makes one, `project check
    /// FILE` says per drive whether it is still the device the project saw.
    Project(ProjectArgs),
}

#[derive(Args, Debug, Clone)]
pub struct ProjectArgs {
    #[command(subcommand)]
    pub command: ProjectCommand,
}

#[derive(Subcommand, Debug, Clone)]
pub enum ProjectCommand {
    /// Make a project of drives, each `NAME=CONNECTION`, e.g. `"X axis=modbus-tcp://
    /// 192.168.2.100:502"` `"Y axis=canopen+socketcan://can0?node=2"`.
    New(ProjectNewArgs),
    /// Ask every drive of the project for its identity (1018h:01 to 04) and say per drive
    /// whether it is the device the project saw: same device, what changed, or why it did
    /// not answer. Exit code 0 when every drive is the same, 1 otherwise.
    Check(ProjectCheckArgs),
    /// List the project's drives: name, connection string, options, watched objects, and
    /// the identity and backup it keeps.
    Show(ProjectFileArg),
    /// Back every drive's settings up into the project (as `od dump` does to a file),
    /// with the identity each reports now. A drive that cannot be read keeps the backup it
    /// had, and says why (exit code 1).
    Backup(ProjectFileArg),
}

#[derive(Args, Debug, Clone)]
pub struct ProjectNewArgs {
    /// The project file to write.
    #[arg(value_name = "FILE.json")]
    pub file: std::path::PathBuf,
    /// The drives, each `NAME=CONNECTION` (see the connection strings below).
    #[arg(value_name = "NAME=URL", required = true)]
    pub drives: Vec<String>,
    /// Ask each drive for its identity now and store it (every drive must answer).
    #[arg(long)]
    pub identify: bool,
    /// Replace the file if it exists.
    #[arg(long)]
    pub force: bool,
}

#[derive(Args, Debug, Clone)]
pub struct ProjectCheckArgs {
    /// The project file.
    #[arg(value_name = "FILE.json")]
    pub file: std::path::PathBuf,
    /// Store the identity each answering drive reports now as the one last seen.
    #[arg(long)]
    pub update: bool,
}

#[derive(Args, Debug, Clone)]
pub struct ProjectFileArg {
    /// The project file.
    #[arg(value_name = "FILE.json")]
    pub file: std::path::PathBuf,
}

#[derive(Args, Debug, Clone)]
pub struct RecordArgs {
    /// Comma-separated: position, velocity, torque, following_error, analog_input,
    /// return_value, pdi_status, digital_inputs, or object addresses such as 2031:00.
    #[arg(long, default_value = "position,velocity,torque,pdi_status")]
    pub signals: String,
    /// Samples per second (the worker's poll rate, 1 to 2000).
    #[arg(long, default_value_t = 500.0, value_name = "HZ")]
    pub rate: f64,
    /// How long to record (after the trigger, with --trigger): 5s, 500ms, 2m.
    #[arg(long, default_value = "5s")]
    pub duration: String,
    /// The file to write: .json for JSON, anything else CSV.
    #[arg(long, value_name = "FILE")]
    pub out: std::path::PathBuf,
    /// Start on a condition: 'position rises 1000', 'velocity falls 0',
    /// 'pdi_status bit 3 rises', 'digital_inputs bit 16 changes'.
    #[arg(long, value_name = "CONDITION")]
    pub trigger: Option<String>,
    /// With --trigger: history kept from before it fired.
    #[arg(long, default_value = "1s")]
    pub pre: String,
    /// With --trigger: how long to wait for it (default: --timeout).
    #[arg(long)]
    pub wait: Option<String>,
}

#[derive(Args, Debug, Clone)]
pub struct OdArgs {
    #[command(subcommand)]
    pub command: OdCommand,
}

#[derive(Subcommand, Debug, Clone)]
pub enum OdCommand {
    /// List objects: index:sub, name, type, access, default and limits; with --link also
    /// the value each one has on the drive (an object that cannot be read shows why).
    List(OdListArgs),
    /// Back the drive's configuration up: every readable and writable setting (no
    /// commands, no process data) with the device's identity, to a JSON file.
    Dump(OdDumpArgs),
    /// Compare the drive with a backup file: each saved object, same or different (and the
    /// entries a restore skips, with the reason: they do not count as differences).
    /// Exit code 0 when the drive matches, 1 when something differs or cannot be read.
    Diff(OdFileArgs),
    /// Write a backup file back: only what differs, in a safe order (configuration, drive
    /// profile, mappings with their procedure, communication, and the settings that can
    /// cut the link last), each write reported, then the drive compared again. Commands,
    /// process data, read-only and unknown objects are never written, whatever the file
    /// says: they are listed as skipped, with the reason.
    Restore(OdRestoreArgs),
}

#[derive(Args, Debug, Clone)]
pub struct OdDumpArgs {
    /// The backup file to write.
    #[arg(long, value_name = "FILE.json")]
    pub out: Option<std::path::PathBuf>,
    /// With --project: the folder that gets one backup per drive, named after the drive
    /// (`X axis` → `X_axis.json`).
    #[arg(value_name = "DIR", conflicts_with = "out")]
    pub dir: Option<std::path::PathBuf>,
    /// Which objects to save: this EDS's instead of the built-in catalog's.
    #[arg(long, value_name = "FILE")]
    pub eds: Option<std::path::PathBuf>,
    /// The node id for the EDS's $NODEID formulas.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u8).range(1..=127))]
    pub node: Option<u8>,
}

// The dictionary a backup file is judged by, for `od diff` and `od restore` (a plain
// comment, so that clap takes no help text from it).
#[derive(Args, Debug, Clone)]
pub struct JudgeArgs {
    /// The dictionary that judges the file: this EDS's instead of the built-in catalog's
    /// (give the one the backup was saved with). Objects it does not know as settings are
    /// skipped, never written.
    #[arg(long, value_name = "FILE")]
    pub eds: Option<std::path::PathBuf>,
    /// The node id for the EDS's $NODEID formulas.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u8).range(1..=127))]
    pub node: Option<u8>,
}

#[derive(Args, Debug, Clone)]
pub struct OdFileArgs {
    /// A backup file written by `od dump` or the window's "Save backup".
    #[arg(value_name = "FILE.json")]
    pub file: std::path::PathBuf,
    /// List the objects that match too, not only the differences.
    #[arg(long)]
    pub all: bool,
    // --eds and --node.
    #[command(flatten)]
    pub judge: JudgeArgs,
}

#[derive(Args, Debug, Clone)]
pub struct OdRestoreArgs {
    /// A backup file written by `od dump` or the window's "Save backup".
    #[arg(value_name = "FILE.json")]
    pub file: std::path::PathBuf,
    /// Show the writes a restore would make, in order, and write nothing.
    #[arg(long)]
    pub dry_run: bool,
    /// After a restore without refusals, store the parameters in the drive (1010h:01 =
    /// "save") so they survive a restart.
    #[arg(long)]
    pub store: bool,
    /// Restore a file saved from another kind of device (vendor or product differ).
    #[arg(long)]
    pub force: bool,
    // --eds and --node.
    #[command(flatten)]
    pub judge: JudgeArgs,
}

#[derive(Args, Debug, Clone)]
pub struct OdListArgs {
    /// Only objects whose index (6064, 1018:01) or name (any part, any case) matches.
    #[arg(long, value_name = "TEXT")]
    pub filter: Option<String>,
    /// The device's dictionary from this EDS or DCF (CiA 306) instead of the built-in
    /// catalog; the catalog still adds units and descriptions the file lacks.
    #[arg(long, value_name = "FILE")]
    pub eds: Option<std::path::PathBuf>,
    /// The node id for the EDS's $NODEID formulas (default: the --link's CANopen node id,
    /// else a DCF's own; without one they stay formulas).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u8).range(1..=127))]
    pub node: Option<u8>,
}

#[derive(Args, Debug, Clone)]
pub struct BenchArgs {
    /// Seconds per measurement.
    #[arg(long, default_value_t = 3.0)]
    pub seconds: f64,
    /// Bench the simulated drive served on loopback in this process, over this bus
    /// (`--serve-sim` alone: Modbus TCP).
    #[arg(long, value_enum, num_args = 0..=1, default_missing_value = "modbus", value_name = "BUS")]
    pub serve_sim: Option<ServedBus>,
    /// The I/O RPI for `--serve-sim enip`, ms.
    #[arg(long, default_value_t = 1)]
    pub rpi: u32,
    /// The Python with pymodbus for the independent FC 23 client that runs against the
    /// same Modbus TCP server (default: $DRIVEDECK_PYTHON, ./.venv/bin/python, python3).
    #[arg(long, value_name = "PATH")]
    pub python: Option<std::path::PathBuf>,
    /// Leave the pymodbus comparison out.
    #[arg(long)]
    pub no_peer: bool,
    /// Instead: start the window N times on the demo and on a served Modbus TCP drive
    /// (needs a display, e.g. Xvfb) and time launch → first frame → first status.
    #[arg(long, value_name = "N")]
    pub startup: Option<u32>,
}

/// The buses `bench --serve-sim` can serve the simulated drive on.
#[derive(ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum ServedBus {
    /// Every bus below, one after the other, with pymodbus on the Modbus server.
    All,
    /// Modbus TCP on loopback.
    Modbus,
    /// EtherNet/IP on loopback, PDI over class 1 I/O.
    Enip,
    /// EtherNet/IP on loopback, PDI over explicit messages.
    EnipExplicit,
    /// CANopen on the in-memory bus.
    Canopen,
}

#[derive(Args, Debug, Clone)]
pub struct DiscoverArgs {
    /// Broadcast on this interface only (its name, e.g. eth0, or its IPv4 address).
    #[arg(long, value_name = "NAME|IP")]
    pub interface: Option<String>,
    /// Also ask this host directly (UDP and TCP).
    #[arg(long, value_name = "HOST")]
    pub host: Option<String>,
    /// The adapters' EtherNet/IP port.
    #[arg(long, default_value_t = 44818)]
    pub port: u16,
    /// Seconds to collect answers.
    #[arg(long, default_value_t = 1.0)]
    pub wait: f64,
}

#[derive(Args, Debug, Clone)]
pub struct WaitArg {
    /// Wait until the command is done, not only accepted.
    #[arg(long)]
    pub wait: bool,
}

/// How an object access travels.
#[derive(ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum Via {
    /// The link's own object access where it has one, the PDI otherwise.
    Auto,
    /// PDI OD-Read / OD-Write.
    Pdi,
    /// The link's own object access only.
    Native,
}

#[derive(Args, Debug, Clone)]
pub struct ReadArgs {
    /// INDEX:SUB in hex, e.g. 1018:01 or 6041.
    pub address: Address,
    /// The object's type, when the catalog does not know it (e.g. u32, i16, string).
    #[arg(long = "type", value_parser = parse_type)]
    pub dtype: Option<DataType>,
    #[arg(long, value_enum, default_value_t = Via::Auto)]
    pub via: Via,
}

#[derive(Args, Debug, Clone)]
pub struct WriteArgs {
    /// INDEX:SUB in hex, e.g. 203B:01.
    pub address: Address,
    /// The value: decimal, 0x… hex, or text for strings.
    #[arg(allow_hyphen_values = true)]
    pub value: String,
    #[arg(long = "type", value_parser = parse_type)]
    pub dtype: Option<DataType>,
    #[arg(long, value_enum, default_value_t = Via::Auto)]
    pub via: Via,
}

#[derive(Args, Debug, Clone)]
pub struct MoveArgs {
    /// Target position (move-abs) or distance (move-rel), 0.1° in factory units.
    #[arg(allow_hyphen_values = true)]
    pub position: i64,
    /// Max speed, rpm in factory units (16 bits: −32768 to 32767).
    #[arg(long, allow_hyphen_values = true)]
    pub speed: i64,
    #[arg(long)]
    pub wait: bool,
}

#[derive(Args, Debug, Clone)]
pub struct TestMoveArgs {
    /// One end, 0.1° in factory units (the test starts by going there).
    #[arg(long, allow_hyphen_values = true)]
    pub from: i64,
    /// The other end.
    #[arg(long, allow_hyphen_values = true)]
    pub to: i64,
    /// Max speed of the moves, rpm in factory units.
    #[arg(long, allow_hyphen_values = true)]
    pub speed: i64,
    /// Seconds to stay at each end after TargetReached (the response settles there).
    #[arg(long, default_value_t = 0.5)]
    pub dwell: f64,
    /// Back-and-forth cycles (each is two steps).
    #[arg(long, default_value_t = 1)]
    pub cycles: u32,
    /// Half the width of the settling band, 0.1° (default: 1 % of the step, at least 1).
    #[arg(long)]
    pub band: Option<f64>,
    /// Keep the run: every sample of every step and a marker with each step's figures,
    /// in a recording (CSV, or JSON for a .json name) the window opens.
    #[arg(long, value_name = "FILE")]
    pub record: Option<std::path::PathBuf>,
}

#[derive(Args, Debug, Clone)]
pub struct TestVelocityArgs {
    /// The speed to step to (and to its opposite), rpm in factory units.
    #[arg(long, allow_hyphen_values = true)]
    pub speed: i64,
    /// Seconds to hold each speed once it is reached.
    #[arg(long, default_value_t = 0.5)]
    pub hold: f64,
    /// Cycles of three steps each.
    #[arg(long, default_value_t = 1)]
    pub cycles: u32,
    /// Half the width of the settling band, rpm (default: 1 % of the speed, at least 1).
    #[arg(long)]
    pub band: Option<f64>,
    /// Keep the run: every sample of every step and a marker with each step's figures,
    /// in a recording (CSV, or JSON for a .json name) the window opens.
    #[arg(long, value_name = "FILE")]
    pub record: Option<std::path::PathBuf>,
}

#[derive(Args, Debug, Clone)]
pub struct VelocityArgs {
    /// Target speed, rpm in factory units.
    #[arg(allow_hyphen_values = true)]
    pub speed: i64,
    /// Wait until the speed is reached.
    #[arg(long)]
    pub wait: bool,
}

#[derive(Args, Debug, Clone)]
pub struct TorqueArgs {
    /// Target torque, ‰ of rated torque.
    #[arg(allow_hyphen_values = true)]
    pub torque: i64,
    /// Max speed, rpm in factory units.
    #[arg(long)]
    pub max_speed: i64,
    /// Set the torque slope 6087h (‰/s) first; the drive's default of 0 never builds up torque.
    #[arg(long)]
    pub slope: Option<u32>,
    #[arg(long)]
    pub wait: bool,
}

#[derive(Args, Debug, Clone)]
pub struct HomeArgs {
    /// Homing method (CiA 402), e.g. 17, 18, 19, 21, 33, 34, 35, 37.
    #[arg(long, allow_hyphen_values = true)]
    pub method: i64,
    #[arg(long)]
    pub wait: bool,
}

#[derive(Args, Debug, Clone)]
pub struct HomeHereArgs {
    /// The value the actual position takes, 0.1°.
    #[arg(allow_hyphen_values = true)]
    pub position: i64,
}

#[derive(Args, Debug, Clone)]
pub struct SimArgs {
    /// Serve Modbus TCP on ADDR:PORT (e.g. 127.0.0.1:1502; 0.0.0.0:502 for the network).
    /// Give it again for another drive on another port.
    #[arg(long, value_name = "ADDR:PORT")]
    pub modbus_tcp: Vec<std::net::SocketAddr>,
    /// Modbus TCP clients at a time; a Nanotec drive allows one.
    #[arg(long, default_value_t = 1, value_name = "N")]
    pub max_clients: usize,
    /// Serve Modbus RTU on this serial port (e.g. one end of a socat pty pair).
    #[arg(long, value_name = "PATH")]
    pub modbus_rtu: Option<String>,
    /// RTU baud rate (Nanotec factory: 19200).
    #[arg(long, default_value_t = 19_200)]
    pub baud: u32,
    /// RTU parity (factory: even).
    #[arg(long, value_enum, default_value_t = CliParity::Even)]
    pub parity: CliParity,
    /// RTU stop bits (factory: 1).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u8).range(1..=2))]
    pub stop_bits: u8,
    /// RTU slave address (factory: 5). Give it again for another drive on the same line.
    #[arg(long, default_values_t = [5u8], value_parser = clap::value_parser!(u8).range(1..=247))]
    pub slave: Vec<u8>,
    /// Word order of 32-bit register pairs: high (Nanotec) or low.
    #[arg(long, value_enum, default_value_t = CliWords::High)]
    pub words: CliWords,
    /// Serve a CANopen node on this SocketCAN interface (e.g. vcan0).
    #[arg(long, value_name = "IFACE")]
    pub can: Option<String>,
    /// Serve a CANopen node behind an emulated slcan adapter on this serial port (one end of
    /// a pty pair: the other end is the host's slcan device).
    #[arg(long, value_name = "PATH")]
    pub slcan: Option<String>,
    /// The simulated node's CANopen node id. Give it again for another drive on the same
    /// bus (--node 5 --node 6).
    #[arg(long, default_values_t = [1u8], value_parser = clap::value_parser!(u8).range(1..=127))]
    pub node: Vec<u8>,
    /// Serve EtherNet/IP on ADDR:PORT (e.g. 127.0.0.1:44818; 0.0.0.0:44818 for the network,
    /// where ListIdentity also answers broadcasts). IPv4 only. Give it again for another
    /// drive (an adapter on another address).
    #[arg(long, value_name = "ADDR:PORT")]
    pub enip: Vec<std::net::SocketAddr>,
    /// The UDP port of class 1 I/O on each --enip address (0: any free port; give 0 for
    /// several adapters on one IP address).
    #[arg(long, default_value_t = 2222, value_name = "PORT")]
    pub enip_io_port: u16,
    /// EtherNet/IP sessions at a time (RegisterSession beyond them gets status 0002h).
    #[arg(long, default_value_t = 8, value_name = "N")]
    pub max_sessions: usize,
    /// Leave out function codes, to simulate a gateway or device without them.
    #[arg(long, value_enum, value_delimiter = ',', value_name = "FC,...")]
    pub without: Vec<Missing>,
    /// Print each drive's state once a second.
    #[arg(long)]
    pub verbose: bool,
    /// The load's inertia coupled to each simulated motor, as a multiple of the motor's
    /// own (0: the motor alone). It shows in closed loop (after an auto setup): a heavier
    /// load lags more behind a move and needs other gains.
    #[arg(long, default_value_t = 0.0, value_name = "RATIO", value_parser = parse_load_inertia)]
    pub load_inertia: f64,
    /// A constant torque against each simulated motor (gravity on a vertical axis), in
    /// thousandths of the rated torque.
    #[arg(long, default_value_t = 0.0, value_name = "PERMILLE", value_parser = parse_load_torque, allow_negative_numbers = true)]
    pub load_torque: f64,
}

fn parse_load_inertia(text: &str) -> Result<f64, String> {
    let ratio: f64 = text
        .parse()
        .map_err(|_| format!("{text:?} is not a number"))?;
    if (0.0..=100.0).contains(&ratio) {
        Ok(ratio)
    } else {
        Err(format!(
            "{text} is outside 0 to 100 (times the motor's inertia)"
        ))
    }
}

fn parse_load_torque(text: &str) -> Result<f64, String> {
    let permille: f64 = text
        .parse()
        .map_err(|_| format!("{text:?} is not a number"))?;
    if (-1000.0..=1000.0).contains(&permille) {
        Ok(permille)
    } else {
        Err(format!(
            "{text} is outside -1000 to 1000 (thousandths of the rated torque)"
        ))
    }
}

/// Function codes the simulated drive can leave out.
#[derive(ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum Missing {
    /// FC 23 Read/Write Multiple Registers (clients fall back to FC 16 + FC 4).
    Fc23,
    /// FC 43 CANopen object access and FC 101 (clients use PDI OD-Read/OD-Write).
    Fc43,
}

/// What an interrupted or timed-out command, or a lost link, leaves the drive in.
#[derive(ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum OnExit {
    /// Set the halt bit: the drive brakes on its ramp and stays energised.
    Halt,
    /// Switch Off: the power stage goes off and the motor coasts.
    SwitchOff,
    /// Leave the drive as it is: it carries on.
    Leave,
}

impl OnExit {
    pub fn action(self) -> crate::worker::LinkLossAction {
        match self {
            OnExit::Halt => crate::worker::LinkLossAction::Halt,
            OnExit::SwitchOff => crate::worker::LinkLossAction::SwitchOff,
            OnExit::Leave => crate::worker::LinkLossAction::Nothing,
        }
    }
}

#[derive(ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum CliParity {
    None,
    Even,
    Odd,
}

#[derive(ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum CliWords {
    High,
    Low,
}

fn parse_type(text: &str) -> Result<DataType, String> {
    let t = text.trim().to_ascii_lowercase();
    let found = DataType::ALL.into_iter().find(|d| {
        d.short_name().eq_ignore_ascii_case(&t)
            || format!("{d:?}").eq_ignore_ascii_case(&t)
            || (t == "string" && *d == DataType::VisibleString)
    });
    found.ok_or_else(|| {
        let names: Vec<String> = DataType::ALL
            .iter()
            .map(|d| d.short_name().to_ascii_lowercase())
            .collect();
        format!("unknown type '{text}': use one of {}", names.join(", "))
    })
}

/// The positional `drivedeck PROJECT.json`: a file name ending in `.json`, so that a
/// mistyped command is not taken for a project.
fn project_path(text: &str) -> Result<std::path::PathBuf, String> {
    let path = std::path::PathBuf::from(text);
    if path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("json"))
    {
        Ok(path)
    } else {
        Err(format!(
            "'{text}' is no command, and no project file (a project's name ends in .json); see --help for the commands"
        ))
    }
}

/// Run the command line. Without a command, the window opens.
pub fn main() -> ExitCode {
    let matches = Cli::command().get_matches();
    let mut cli = Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit());
    init_tracing();
    let given = |id: &str| matches.value_source(id) == Some(ValueSource::CommandLine);
    // Built once from the flags and handed to every command that opens a session.
    let mut context = Context {
        policy: Policy {
            on_exit: cli.on_exit.action(),
            lost_after: cli.lost_after,
        },
        expected: None,
    };
    if let Some(Command::Commission(args)) = &cli.command {
        // A procedure covers every drive of a project (or those named) itself.
        let project = match &cli.project {
            Some(path) => match project_cmd::load(path) {
                Ok(project) => Some((path.clone(), project)),
                Err(f) => {
                    report::print_error(&f.message, cli.json);
                    return ExitCode::from(f.code);
                }
            },
            None => None,
        };
        if project.is_some() && cli.link.is_some() {
            report::print_error("give --link or --project, not both", cli.json);
            return ExitCode::from(EXIT_USAGE);
        }
        return commission::run(
            args,
            cli.link.as_ref(),
            project.as_ref().map(|(p, pr)| (p.as_path(), pr)),
            cli.drive.as_deref(),
            cli.json,
            timeout(&cli),
            cli.trace,
            &context,
        );
    }
    let target = match project_cmd::target(&cli) {
        Ok(target) => target,
        Err(f) => {
            report::print_error(&f.message, cli.json);
            return ExitCode::from(f.code);
        }
    };
    let window = match target {
        project_cmd::Target::None => match &cli.link {
            Some(link) => crate::ui::Opening::Link(link.clone()),
            None => crate::ui::Opening::Last,
        },
        project_cmd::Target::Window {
            project,
            path,
            drive,
        } => crate::ui::Opening::Project {
            project,
            path,
            show: drive.map(|d| d.name),
        },
        project_cmd::Target::Drive(drive) => {
            // The drive's own options, unless the command line gives its own.
            if !given("on_exit") {
                context.policy.on_exit = drive.options.on_link_loss;
            }
            if !given("lost_after") {
                context.policy.lost_after = drive.options.lost_after;
            }
            context.expect_device(&drive);
            cli.link = Some(drive.link.clone());
            crate::ui::Opening::Link(drive.link)
        }
        project_cmd::Target::Every(project) => {
            return project_cmd::every_drive(&project, &cli, &context);
        }
    };
    match cli.command.clone() {
        None => match crate::ui::run_window(window) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("drivedeck: the window could not open: {e}");
                eprintln!(
                    "(no display? run one-shot commands instead, e.g. `drivedeck --link sim status`)"
                );
                ExitCode::from(EXIT_USAGE)
            }
        },
        Some(Command::Project(args)) => project_cmd::run(&args, &cli, &context),
        Some(Command::InstallFiles { dir }) => install_files::run(&dir),
        Some(Command::Sim(args)) => serve::run(&args),
        Some(Command::Bench(args)) => bench::run(cli.link.clone(), &args, cli.json),
        Some(Command::TestMove(args)) => {
            let link = cli.link.clone().unwrap_or(LinkSpec::Sim);
            test_move::run(&link, &args, cli.json, timeout(&cli), cli.trace, &context)
        }
        Some(Command::Gains) => {
            let link = cli.link.clone().unwrap_or(LinkSpec::Sim);
            gains::run(&link, cli.json, timeout(&cli), cli.trace, &context)
        }
        Some(Command::TestVelocity(args)) => {
            let link = cli.link.clone().unwrap_or(LinkSpec::Sim);
            test_move::run_velocity(&link, &args, cli.json, timeout(&cli), cli.trace, &context)
        }
        Some(Command::Spectrum(args)) => spectrum::run(&args, cli.json),
        Some(Command::Verify(args)) => verify::run(&args, cli.json),
        Some(Command::Io) => {
            let link = cli.link.clone().unwrap_or(LinkSpec::Sim);
            io::run_io(&link, cli.json, timeout(&cli), cli.trace, &context)
        }
        Some(Command::Output(args)) => {
            let link = cli.link.clone().unwrap_or(LinkSpec::Sim);
            io::run_output(&link, &args, cli.json, timeout(&cli), cli.trace, &context)
        }
        Some(Command::Nanoj(args)) => {
            let link = cli.link.clone().unwrap_or(LinkSpec::Sim);
            nanoj::run(&link, &args, cli.json, timeout(&cli), cli.trace, &context)
        }
        Some(command @ (Command::Store | Command::Defaults(_) | Command::Reboot)) => {
            let link = cli.link.clone().unwrap_or(LinkSpec::Sim);
            let what = match command {
                Command::Defaults(a) => storage::What::Defaults { reboot: a.reboot },
                Command::Reboot => storage::What::Reboot,
                _ => storage::What::Store,
            };
            storage::run(&link, what, cli.json, timeout(&cli), cli.trace, &context)
        }
        Some(Command::Discover(args)) => oneshot::discover(&args, cli.json),
        Some(Command::Record(args)) => {
            let link = cli.link.clone().unwrap_or(LinkSpec::Sim);
            record::run(&link, &args, cli.json, timeout(&cli), cli.trace, &context)
        }
        Some(Command::Od(args)) => od::run(
            cli.link.as_ref(),
            &args,
            cli.json,
            timeout(&cli),
            cli.trace,
            &context,
        ),
        Some(command) => {
            let link = cli.link.clone().unwrap_or(LinkSpec::Sim);
            oneshot::run(
                &link,
                &command,
                cli.json,
                timeout(&cli),
                cli.trace,
                &context,
            )
        }
    }
}

/// The shortest and the longest `--timeout`, in seconds (a tenth of a second, a day).
const TIMEOUT_RANGE: std::ops::RangeInclusive<f64> = 0.1..=86_400.0;

/// `--timeout` as given: seconds from a tenth of a second to a day; anything else is
/// refused with the range (0 would not wait at all, a negative or non-finite one means
/// nothing).
fn parse_timeout(text: &str) -> Result<f64, String> {
    let seconds: f64 = text
        .trim()
        .parse()
        .map_err(|_| format!("{text:?} is not a number of seconds (e.g. 30 or 2.5)"))?;
    if TIMEOUT_RANGE.contains(&seconds) {
        Ok(seconds)
    } else {
        Err(format!(
            "{text} s is out of range: give {} to {} seconds (a tenth of a second to a day)",
            TIMEOUT_RANGE.start(),
            TIMEOUT_RANGE.end()
        ))
    }
}

/// `--timeout` (checked by [`parse_timeout`]).
fn timeout(cli: &Cli) -> Duration {
    Duration::from_secs_f64(
        cli.timeout
            .clamp(*TIMEOUT_RANGE.start(), *TIMEOUT_RANGE.end()),
    )
}

/// Colour codes in the log only on a terminal, and never when `NO_COLOR` is set to
/// anything but the empty string (no-color.org): redirected stderr is plain text.
fn colour_on_stderr() -> bool {
    use std::io::IsTerminal;
    let no_color = std::env::var_os("NO_COLOR").is_some_and(|v| !v.is_empty());
    !no_color && std::io::stderr().is_terminal()
}

fn init_tracing() {
    let filter = tracing_subscriber::EnvFilter::try_from_env("DRIVEDECK_LOG")
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn"));
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(colour_on_stderr())
        .try_init();
}
