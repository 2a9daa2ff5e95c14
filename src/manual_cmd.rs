//! `anguilla completions SHELL` and `anguilla man DIR`: the shell
//! completions and the man pages, both generated from the command line's
//! own definition ([`crate::Cli`]), so they list exactly the subcommands and
//! flags this build has (the `remote` and `foxglove` features add theirs).

use crate::output::{out, outln};
use anyhow::{Context, Result};
use std::path::{Path, PathBuf};

/// Arguments of `anguilla completions`.
#[derive(clap::Args, Debug)]
pub struct CompletionsArgs {
    /// The shell to complete for; the script goes to standard output.
    #[arg(value_enum)]
    pub shell: clap_complete::Shell,
}

/// Arguments of `anguilla man`.
#[derive(clap::Args, Debug)]
pub struct ManArgs {
    /// Directory to write the pages to (made if missing): anguilla.1, and
    /// one page per subcommand (anguilla-run.1, anguilla-config-check.1, ...).
    pub dir: PathBuf,
}

/// Prints the completion script of `args.shell` for `cmd`.
pub fn completions(args: &CompletionsArgs, mut cmd: clap::Command) -> Result<()> {
    // clap_complete panics when its writer fails: give it memory, then
    // write to standard output with an error that names it.
    let mut script = Vec::new();
    clap_complete::generate(args.shell, &mut cmd, "anguilla", &mut script);
    out!("{}", String::from_utf8_lossy(&script))
}

/// Writes a man page for `cmd` and for every subcommand it shows (hidden
/// ones have none) into `args.dir`, and names each file written.
pub fn man(args: &ManArgs, cmd: clap::Command) -> Result<()> {
    std::fs::create_dir_all(&args.dir)
        .with_context(|| format!("making the directory {}", args.dir.display()))?;
    let mut cmd = cmd.disable_help_subcommand(true);
    // Gives every subcommand its display name (anguilla-config-check), the
    // name of its page.
    cmd.build();
    // Every page's footer names the program and its version (clap_mangen
    // would name a subcommand's page after the subcommand alone).
    let source = format!("anguilla {}", cmd.get_version().unwrap_or_default());
    let mut written = Vec::new();
    write_pages(&cmd, &source, &args.dir, &mut written)?;
    for path in &written {
        outln!("{}", path.display())?;
    }
    Ok(())
}

/// Depth first, as `clap_mangen::generate_to`, but keeping the paths.
fn write_pages(
    cmd: &clap::Command,
    source: &str,
    dir: &Path,
    written: &mut Vec<PathBuf>,
) -> Result<()> {
    let man = clap_mangen::Man::new(cmd.clone()).source(source);
    let path = dir.join(man.get_filename());
    let mut page = Vec::new();
    man.render(&mut page)?;
    anguilla::user_file::replace(&path, &page)?;
    written.push(path);
    for sub in cmd.get_subcommands().filter(|s| !s.is_hide_set()) {
        write_pages(sub, source, dir, written)?;
    }
    Ok(())
}
