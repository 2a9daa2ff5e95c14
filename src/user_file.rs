//! Writing a user's file so that nobody else can redirect the write, and
//! so that no reader ever sees half of it (issue 45): what `anguilla config
//! set-bus`, `calibrate --write` and the tools' `--out`/`--csv`/man-page
//! outputs use to replace a file.
//!
//! [`Replacement`] writes a new file beside the target under a random name
//! created with `O_CREAT | O_EXCL | O_NOFOLLOW` (mode 0600 until it is
//! done), so a symlink or file planted at any name a user could predict is
//! never opened; gives it, on its descriptor, the old file's mode, owner
//! and group (a `root:anguilla 0640` configuration stays one); syncs it;
//! renames it over the target (a reader sees the old file or the new one,
//! never a mix, and a failure leaves the old one); and syncs the directory.
//!
//! A target that is a symlink is written through to the file it names,
//! which keeps the symlink (a configuration kept elsewhere and linked into
//! `/etc/anguilla` stays linked). A symlink is followed only where the
//! kernel's `fs.protected_symlinks` would follow it: not one in a sticky
//! world-writable directory (`/tmp`) that neither the caller nor the
//! directory's owner owns. A symlink to nothing is refused (it would make
//! the tool create a file wherever the symlink's owner chose), and so is a
//! target that is not a regular file.
//!
//! The new file is a new inode: hard links to the old one keep the old
//! contents, and extended attributes and ACLs are not copied.
//!
//! A recording's files are never replaced (issue 46): a file in a session
//! directory that `anguilla run` recorded ([`recording_of`]) is refused by
//! name. Tools that write beside a recording (`anguilla export`) make a
//! new file with [`Replacement::create`] (the same temporary file, renamed
//! only where no file is: `RENAME_NOREPLACE`), at a name [`free_name`]
//! picks or the user gives.
//!
//! ```no_run
//! anguilla::user_file::replace(std::path::Path::new("anguilla.toml"), b"[bus]\n")?;
//! # Ok::<(), anyhow::Error>(())
//! ```

use std::ffi::{CString, OsStr, OsString};
use std::fs::File;
use std::io::Write;
use std::os::fd::{AsRawFd as _, FromRawFd as _, OwnedFd};
use std::os::unix::ffi::{OsStrExt as _, OsStringExt as _};
use std::os::unix::fs::{MetadataExt as _, PermissionsExt as _};
use std::path::{Path, PathBuf};

use anyhow::{Context as _, bail};

/// At most this many symlinks are followed (Linux's own limit).
const MAX_HOPS: usize = 40;

/// The files only `anguilla run`'s recorder writes: a directory holding
/// one of them is a recording (docs/data.md "The session directory").
const RECORDING_MARKS: [&str; 2] = ["state.bin", "session.log"];

/// The recording (session directory) `path` is a file of, if it is one:
/// its directory holds what only the recorder writes (`state.bin` or
/// `session.log`). Every file there is the recording's or was written
/// beside it, and no tool replaces it.
pub fn recording_of(path: &Path) -> Option<PathBuf> {
    let dir = parent(path);
    RECORDING_MARKS
        .iter()
        .any(|m| std::fs::symlink_metadata(dir.join(m)).is_ok())
        .then(|| dir.to_path_buf())
}

/// The first name in `dir` that nothing has: `STEM.EXT`, else `STEM-2.EXT`,
/// `STEM-3.EXT`... (as the recorder names its sessions). Another process
/// could take it before it is written: [`Replacement::create`] then fails
/// and names it, and never replaces it.
pub fn free_name(dir: &Path, stem: &str, ext: &str) -> anyhow::Result<PathBuf> {
    for n in 1..=9999u32 {
        let name = if n == 1 {
            format!("{stem}.{ext}")
        } else {
            format!("{stem}-{n}.{ext}")
        };
        let p = dir.join(name);
        match std::fs::symlink_metadata(&p) {
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(p),
            Err(e) => return Err(e).with_context(|| format!("reading {}", p.display())),
            Ok(_) => {}
        }
    }
    bail!(
        "{}: {stem}.{ext} to {stem}-9999.{ext} all exist (name the output yourself)",
        dir.display()
    )
}

/// What is kept of the file being replaced.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Keep {
    mode: u32,
    /// Owner and group; `None` for a new file (the caller's, or the
    /// directory's group under a set-group-id directory).
    owner: Option<(u32, u32)>,
}

/// Where `path` really is: the file it names after its symlinks (each
/// checked as `fs.protected_symlinks` does), and whether it exists. The
/// error names `path` and what is wrong with it.
pub fn resolve(path: &Path) -> anyhow::Result<(PathBuf, Option<std::fs::Metadata>)> {
    let shown = path.display();
    let mut p = path.to_path_buf();
    // SAFETY: geteuid cannot fail.
    let euid = unsafe { libc::geteuid() };
    for _ in 0..=MAX_HOPS {
        let m = match std::fs::symlink_metadata(&p) {
            Ok(m) => m,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound && p == path => {
                return Ok((p, None));
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => bail!(
                "{shown} is a symlink to {}, which does not exist: refusing to create a file \
                 through a symlink (remove the symlink, or create its target first)",
                p.display()
            ),
            Err(e) => return Err(e).with_context(|| format!("{shown}: reading {}", p.display())),
        };
        if m.file_type().is_symlink() {
            let dir = parent(&p);
            let d = std::fs::metadata(dir)
                .with_context(|| format!("{shown}: reading {}", dir.display()))?;
            // sticky (0o1000) and writable by others (0o002)
            if d.mode() & 0o1002 == 0o1002 && m.uid() != euid && m.uid() != d.uid() {
                bail!(
                    "{shown}: {} is a symlink owned by uid {} in the world-writable sticky \
                     directory {}, owned by neither you nor the directory's owner: refusing to \
                     follow it (as the kernel's fs.protected_symlinks refuses)",
                    p.display(),
                    m.uid(),
                    dir.display()
                );
            }
            let to = std::fs::read_link(&p)
                .with_context(|| format!("{shown}: reading the symlink {}", p.display()))?;
            p = if to.is_absolute() { to } else { dir.join(to) };
            continue;
        }
        if !m.file_type().is_file() {
            bail!(
                "{shown}{}: not a regular file (expected a file to replace)",
                if p == path {
                    String::new()
                } else {
                    format!(" (through its symlinks, {})", p.display())
                }
            );
        }
        return Ok((p, Some(m)));
    }
    bail!("{shown}: more than {MAX_HOPS} symlinks in a row")
}

/// `p`'s directory (`.` for a bare name).
fn parent(p: &Path) -> &Path {
    match p.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

/// The process's file-mode creation mask.
fn umask() -> u32 {
    // SAFETY: umask cannot fail; it is set back at once (the tools create
    // no files on other threads meanwhile).
    let old = unsafe { libc::umask(0o022) };
    // SAFETY: as above.
    unsafe { libc::umask(old) };
    old as u32
}

fn random_hex() -> std::io::Result<String> {
    let mut b = [0u8; 8];
    // SAFETY: `b` is valid for 8 bytes of writes.
    let n = unsafe { libc::getrandom(b.as_mut_ptr().cast(), b.len(), 0) };
    if n != b.len() as isize {
        return Err(std::io::Error::last_os_error());
    }
    Ok(b.iter().map(|x| format!("{x:02x}")).collect())
}

fn cstr(name: &OsStr) -> std::io::Result<CString> {
    CString::new(name.as_bytes()).map_err(|_| {
        std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "a file name with a NUL byte",
        )
    })
}

/// A file being written to replace another: [`Write`] into it, then
/// [`commit`](Self::commit). Dropped uncommitted, it removes its temporary
/// file and leaves the target as it was.
pub struct Replacement {
    /// The target's directory, open: the temporary file is created, renamed
    /// and synced relative to it, whatever happens to its path meanwhile.
    dir: File,
    tmp: CString,
    name: CString,
    file: Option<File>,
    keep: Keep,
    /// The file replaced (the target after its symlinks).
    target: PathBuf,
    /// The path as the user gave it, for messages.
    shown: PathBuf,
    /// Made by [`Replacement::create`]: committed only where no file is.
    exclusive: bool,
}

impl Replacement {
    /// Starts replacing (or creating) `path`: resolves it ([`resolve`]) and
    /// creates the temporary file beside the file it names.
    ///
    /// A file of a recording ([`recording_of`]) is refused, naming it.
    pub fn new(path: &Path) -> anyhow::Result<Self> {
        let (target, meta) = resolve(path)?;
        if meta.is_some()
            && let Some(rec) = recording_of(&target)
        {
            bail!(
                "{}: a file of the recording {}, which no tool rewrites (write to a new file \
                 instead, or to a copy of the file outside the recording)",
                path.display(),
                rec.display()
            );
        }
        Self::start(path, target, meta, false)
    }

    /// Starts writing the new file `path`, which must not exist: fails,
    /// naming it, if anything (a file, a symlink, a directory) is there, and
    /// [`commit`](Self::commit) fails, leaving it alone, if anything is
    /// there by then (a rename that never replaces: `RENAME_NOREPLACE`).
    /// A reader never sees half of it.
    pub fn create(path: &Path) -> anyhow::Result<Self> {
        match std::fs::symlink_metadata(path) {
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => return Err(e).with_context(|| format!("reading {}", path.display())),
            Ok(_) => bail!("{}: already exists (never replaced)", path.display()),
        }
        Self::start(path, path.to_path_buf(), None, true)
    }

    fn start(
        path: &Path,
        target: PathBuf,
        meta: Option<std::fs::Metadata>,
        exclusive: bool,
    ) -> anyhow::Result<Self> {
        let shown = path.display();
        let keep = match &meta {
            Some(m) => Keep {
                mode: m.mode() & 0o7777,
                owner: Some((m.uid(), m.gid())),
            },
            None => Keep {
                mode: 0o666 & !umask(),
                owner: None,
            },
        };
        let Some(name) = target.file_name() else {
            bail!("{shown}: not a file name (expected a path to a file)");
        };
        let dir_path = parent(&target);
        let dir = File::open(dir_path)
            .with_context(|| format!("{shown}: opening its directory {}", dir_path.display()))?;
        // A name of at most 255 bytes whatever the target's length.
        let stem = &name.as_bytes()[..name.len().min(200)];
        let mut last = None;
        for _ in 0..16 {
            let mut tmp = b".".to_vec();
            tmp.extend_from_slice(stem);
            tmp.push(b'.');
            tmp.extend_from_slice(random_hex()?.as_bytes());
            tmp.extend_from_slice(b".tmp");
            let tmp = cstr(&OsString::from_vec(tmp))?;
            // SAFETY: `dir` is an open directory and `tmp` a NUL-terminated
            // name; the descriptor returned is owned below.
            let fd = unsafe {
                libc::openat(
                    dir.as_raw_fd(),
                    tmp.as_ptr(),
                    libc::O_WRONLY
                        | libc::O_CREAT
                        | libc::O_EXCL
                        | libc::O_NOFOLLOW
                        | libc::O_CLOEXEC,
                    0o600 as libc::c_uint,
                )
            };
            if fd < 0 {
                let e = std::io::Error::last_os_error();
                if e.kind() == std::io::ErrorKind::AlreadyExists {
                    last = Some(e);
                    continue;
                }
                return Err(e).with_context(|| {
                    format!("{shown}: creating a new file in {}", dir_path.display())
                });
            }
            // SAFETY: `fd` was just opened and nothing else owns it.
            let file = File::from(unsafe { OwnedFd::from_raw_fd(fd) });
            return Ok(Self {
                dir,
                tmp,
                name: cstr(name)?,
                file: Some(file),
                keep,
                target: target.clone(),
                shown: path.to_path_buf(),
                exclusive,
            });
        }
        Err(last.unwrap_or_else(|| std::io::Error::other("no free name")))
            .with_context(|| format!("{shown}: 16 random names in {} taken", dir_path.display()))
    }

    /// Another descriptor of the new file, for a writer that wants a
    /// [`File`] of its own (an MCAP writer): what it writes is committed
    /// with this replacement, once it has flushed and dropped it.
    pub fn try_clone_file(&self) -> anyhow::Result<File> {
        match &self.file {
            Some(f) => Ok(f.try_clone()?),
            None => bail!("{}: already committed", self.shown.display()),
        }
    }

    /// The file replaced: the path given after its symlinks.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Gives the new file the old one's owner, group and mode, syncs it,
    /// renames it over the target and syncs the directory. Returns the file
    /// replaced.
    pub fn commit(mut self) -> anyhow::Result<PathBuf> {
        let shown = self.shown.display().to_string();
        let Some(mut file) = self.file.take() else {
            bail!("{shown}: already committed");
        };
        let done = (|| -> anyhow::Result<()> {
            file.flush()?;
            if let Some((uid, gid)) = self.keep.owner {
                std::os::unix::fs::fchown(&file, Some(uid), Some(gid)).with_context(|| {
                    format!(
                        "giving the new file the owner and group of the old one ({uid}:{gid}): \
                         run as root or as its owner"
                    )
                })?;
            }
            // after chown, which clears the set-id bits
            file.set_permissions(std::fs::Permissions::from_mode(self.keep.mode))
                .context("giving the new file the mode of the old one")?;
            file.sync_all().context("syncing the new file")?;
            drop(file);
            if self.exclusive {
                self.rename_noreplace()?;
            } else {
                // SAFETY: both names are NUL-terminated, relative to the
                // open directory.
                let r = unsafe {
                    libc::renameat(
                        self.dir.as_raw_fd(),
                        self.tmp.as_ptr(),
                        self.dir.as_raw_fd(),
                        self.name.as_ptr(),
                    )
                };
                if r != 0 {
                    return Err(std::io::Error::last_os_error())
                        .context("renaming it over the old");
                }
            }
            // renamed: nothing to remove on drop
            self.tmp = CString::default();
            self.dir.sync_all().context("syncing the directory")?;
            Ok(())
        })();
        done.with_context(|| format!("writing {shown}"))?;
        Ok(self.target.clone())
    }
}

impl Replacement {
    /// Renames the temporary file to the target's name where no file is
    /// (`renameat2(RENAME_NOREPLACE)`; on a file system without it, a hard
    /// link, which also never replaces, and the temporary name removed).
    fn rename_noreplace(&self) -> anyhow::Result<()> {
        let d = self.dir.as_raw_fd();
        let taken = || {
            anyhow::anyhow!(
                "{} appeared meanwhile: it is not replaced (choose another name)",
                self.shown.display()
            )
        };
        // SAFETY: both names are NUL-terminated, relative to the open
        // directory `d`; the syscall reads them and nothing else.
        let r = unsafe {
            libc::syscall(
                libc::SYS_renameat2,
                d,
                self.tmp.as_ptr(),
                d,
                self.name.as_ptr(),
                libc::RENAME_NOREPLACE,
            )
        };
        if r == 0 {
            return Ok(());
        }
        let e = std::io::Error::last_os_error();
        match e.raw_os_error() {
            Some(libc::EEXIST) => return Err(taken()),
            Some(libc::EINVAL) | Some(libc::ENOSYS) => {}
            _ => return Err(e).context("renaming it to its name"),
        }
        // SAFETY: as above; linkat follows no symlink (flags 0).
        let r = unsafe { libc::linkat(d, self.tmp.as_ptr(), d, self.name.as_ptr(), 0) };
        if r != 0 {
            let e = std::io::Error::last_os_error();
            if e.raw_os_error() == Some(libc::EEXIST) {
                return Err(taken());
            }
            return Err(e).context("linking it to its name");
        }
        // SAFETY: our own temporary name, relative to `d`.
        unsafe { libc::unlinkat(d, self.tmp.as_ptr(), 0) };
        Ok(())
    }
}

impl Write for Replacement {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        match &mut self.file {
            Some(f) => f.write(buf),
            None => Err(std::io::Error::other("already committed")),
        }
    }

    fn flush(&mut self) -> std::io::Result<()> {
        match &mut self.file {
            Some(f) => f.flush(),
            None => Ok(()),
        }
    }
}

impl Drop for Replacement {
    fn drop(&mut self) {
        if !self.tmp.is_empty() {
            // SAFETY: a NUL-terminated name relative to the open directory;
            // unlinkat removes the name (ours, made with O_EXCL) and follows
            // nothing.
            unsafe { libc::unlinkat(self.dir.as_raw_fd(), self.tmp.as_ptr(), 0) };
        }
    }
}

/// Replaces (or creates) `path` with `contents`, as [`Replacement`] does.
/// Returns the file written (the path after its symlinks).
pub fn replace(path: &Path, contents: &[u8]) -> anyhow::Result<PathBuf> {
    let mut r = Replacement::new(path)?;
    r.write_all(contents)
        .with_context(|| format!("writing {}", path.display()))?;
    r.commit()
}

/// Creates `path` for a recording or an output that must never replace
/// anything: fails, naming it, if anything (a file, a symlink) is there.
pub fn create_new(path: &Path) -> anyhow::Result<File> {
    use std::os::unix::fs::OpenOptionsExt as _;
    std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .custom_flags(libc::O_NOFOLLOW | libc::O_CLOEXEC)
        .open(path)
        .map_err(|e| {
            if e.kind() == std::io::ErrorKind::AlreadyExists {
                anyhow::anyhow!(
                    "{}: already exists (a recording is never replaced: name a new file, or \
                     move that one away)",
                    path.display()
                )
            } else {
                anyhow::Error::new(e).context(format!("creating {}", path.display()))
            }
        })
}

/// `text` (a TOML document) with `entries` set in its table `table` (made
/// at the end if missing), every other byte kept: comments, layout,
/// strings (a `[bus]` or `spec =` inside a multi-line string is a string's
/// text, not a header or a key: the document is parsed, not scanned by
/// line). A value replaced keeps its comment after it. The error says
/// what is not TOML, or that `table` is not a table.
pub fn set_toml(
    text: &str,
    table: &str,
    entries: &[(&str, toml_edit::Value)],
) -> anyhow::Result<String> {
    let mut doc: toml_edit::DocumentMut = text
        .parse()
        .map_err(|e| anyhow::anyhow!("not a TOML file: {e}"))?;
    let item = doc.entry(table).or_insert(toml_edit::table());
    let Some(t) = item.as_table_like_mut() else {
        bail!(
            "its `{table}` is not a table but {} (expected one [{table}] table)",
            item.type_name()
        );
    };
    for (key, value) in entries {
        match t.get_mut(key).and_then(toml_edit::Item::as_value_mut) {
            Some(old) => {
                let decor = old.decor().clone();
                *old = value.clone();
                *old.decor_mut() = decor;
            }
            None => {
                t.insert(key, toml_edit::Item::Value(value.clone()));
            }
        }
    }
    Ok(doc.to_string())
}

#[cfg(test)]
mod tests;
