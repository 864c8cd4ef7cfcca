//! `drivedeck install-files DIR` (hidden): the files a package installs beside the binary,
//! generated from the command line's own definitions so they never disagree with it — the
//! man pages (`drivedeck.1`, one `drivedeck-COMMAND.1` per command), the shell
//! completions for bash (`drivedeck.bash`), zsh (`_drivedeck`) and fish (`drivedeck.fish`),
//! and the user guide as HTML (`guide/index.html` …, its pictures beside it in `img/`
//! where the package installs them).

use std::path::Path;
use std::process::ExitCode;

use clap::CommandFactory;
use clap_complete::Shell;

use super::Cli;

/// Write the man pages and completions into `dir`: the files written, or why not.
pub fn write(dir: &Path) -> Result<Vec<String>, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot make {}: {e}", dir.display()))?;
    let mut written = vec![];
    let command = Cli::command();
    let mut page = |name: String, command: clap::Command| -> Result<(), String> {
        let mut bytes = vec![];
        clap_mangen::Man::new(command)
            .render(&mut bytes)
            .map_err(|e| format!("the man page {name}: {e}"))?;
        let path = dir.join(&name);
        crate::file::write_whole(&path, &bytes)
            .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
        written.push(name);
        Ok(())
    };
    page("drivedeck.1".into(), command.clone())?;
    for sub in command.get_subcommands().filter(|s| !s.is_hide_set()) {
        let name = format!("drivedeck-{}", sub.get_name());
        page(format!("{name}.1"), sub.clone().name(name))?;
    }
    for shell in [Shell::Bash, Shell::Zsh, Shell::Fish] {
        let mut command = Cli::command();
        let path = clap_complete::generate_to(shell, &mut command, "drivedeck", dir)
            .map_err(|e| format!("the {shell} completion: {e}"))?;
        written.push(
            path.file_name()
                .map_or_else(String::new, |n| n.to_string_lossy().into_owned()),
        );
    }
    let index = crate::guide::write(&dir.join("guide"), "img")?;
    written.push(format!("guide/{}", crate::guide::INDEX));
    debug_assert!(index.ends_with(crate::guide::INDEX));
    Ok(written)
}

pub fn run(dir: &Path) -> ExitCode {
    match write(dir) {
        Ok(files) => {
            println!("wrote {} file(s) to {}", files.len(), dir.display());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("drivedeck: {e}");
            ExitCode::from(super::EXIT_FAILED)
        }
    }
}
