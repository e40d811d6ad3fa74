//! Where a command's files go, written all or nothing: every file goes under a temporary name in
//! the output folder and is renamed into place only when the whole command has succeeded. A
//! command interrupted by a signal removes its temporaries before it exits.

use crate::error::{CliError, Context as _};
use liebayes::experiments::Shard;
use std::fs;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, PoisonError};

/// The temporaries of every [`Output`] not yet committed or removed, for [`remove_staged`]. A
/// temporary is added under this lock as it is created and leaves it under the lock as it is
/// renamed or removed, so that a signal never finds one half done.
static STAGED: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// The staged temporaries (a panic elsewhere does not make the list unusable).
fn staged() -> MutexGuard<'static, Vec<PathBuf>> {
    STAGED.lock().unwrap_or_else(PoisonError::into_inner)
}

/// Drops `temporary` from the staged list (it has been renamed or removed).
fn unstage(staged: &mut Vec<PathBuf>, temporary: &Path) {
    staged.retain(|t| t != temporary);
}

/// Removes every staged temporary and keeps the lock, so that no file is staged after it (the
/// caller exits); returns how many were removed.
fn remove_staged() -> (usize, MutexGuard<'static, Vec<PathBuf>>) {
    let mut staged = staged();
    let removed = staged
        .drain(..)
        .filter(|t| fs::remove_file(t).is_ok())
        .count();
    (removed, staged)
}

/// From now on, SIGINT, SIGTERM or SIGHUP removes every staged temporary, says so on stderr in one
/// line and exits with 128 + the signal's number, as the shell reports a process the signal
/// killed. Without it an interrupted command would leave its hidden temporaries in the output
/// folder (the final names are never touched before the commit either way).
///
/// # Errors
/// The handler cannot be installed.
#[cfg(unix)]
pub fn remove_staged_on_signal() -> Result<(), CliError> {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    let mut signals = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP])
        .context(|| "installing the interrupt handler".to_owned())?;
    std::thread::spawn(move || {
        if let Some(signal) = signals.forever().next() {
            let (removed, _held) = remove_staged();
            let _ = writeln!(
                std::io::stderr().lock(),
                "liebayes: interrupted by signal {signal}: removed {removed} unfinished files"
            );
            std::process::exit(128 + signal);
        }
    });
    Ok(())
}

/// Signals are not handled off Unix: an interrupted command may leave its temporaries.
///
/// # Errors
/// None.
#[cfg(not(unix))]
pub fn remove_staged_on_signal() -> Result<(), CliError> {
    Ok(())
}

/// The output settings every command shares.
#[derive(clap::Args, Debug, Clone)]
pub struct OutputArgs {
    /// Folder for the tables, plots and JSON summary (created if needed; nothing is written without
    /// it).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Run only shard K of N of every study (1 <= K <= N; the runs split into N contiguous
    /// ranges). A partial shard saves only its JSON summary, for `liebayes merge`.
    #[arg(long, value_name = "K/N", default_value = "1/1")]
    pub shard: Shard,
}

/// The longest file name accepted (bytes), well below every file system's limit of 255.
const MAX_NAME: usize = 120;

/// A command's files, pending until [`commit`](Self::commit): each is written under a temporary
/// name beside its final one, and dropping the value uncommitted removes them all (and the
/// output folder, if [`prepare`] created it and it is empty).
#[derive(Debug)]
pub struct Output {
    dir: Option<PathBuf>,
    /// (temporary, final) paths of the files written so far.
    pending: Vec<(PathBuf, PathBuf)>,
    /// Whether [`prepare`] created the folder, until the commit.
    created: bool,
}

/// Checks `--shard` against `--out`, creates the output folder if needed and proves it writable
/// (a probe file created and removed), before any work is done.
///
/// # Errors
/// A shard other than 1/1 without `--out` (its partial summary would be lost), or a folder that
/// cannot be created or written; the message names the folder and the reason.
pub fn prepare(args: &OutputArgs) -> Result<Output, CliError> {
    let Some(dir) = &args.out else {
        if args.shard != Shard::WHOLE {
            return Err(format!(
                "--shard {} needs --out DIR: a partial study is only useful saved, for `liebayes merge`",
                args.shard
            ).into());
        }
        return Ok(Output {
            dir: None,
            pending: Vec::new(),
            created: false,
        });
    };
    let cannot = |what: &str| {
        format!(
            "cannot {what} the output folder {} (choose a writable --out DIR)",
            dir.display()
        )
    };
    let created = !dir.exists();
    fs::create_dir_all(dir).context(|| cannot("create"))?;
    let output = Output {
        dir: Some(dir.clone()),
        pending: Vec::new(),
        created,
    };
    let probe = dir.join(format!(".liebayes-probe-{}", std::process::id()));
    fs::File::create(&probe).context(|| cannot("write into"))?;
    fs::remove_file(&probe).context(|| cannot("write into"))?;
    Ok(output)
}

impl Output {
    /// The output folder, if files are to be written.
    pub fn dir(&self) -> Option<&Path> {
        self.dir.as_deref()
    }

    /// Writes `bytes` as the file `name` of the output folder, under a temporary name until
    /// [`commit`](Self::commit): [`write_with`](Self::write_with) for bytes already in memory.
    ///
    /// # Errors
    /// As [`write_with`](Self::write_with).
    pub fn write(&mut self, name: &str, bytes: &[u8]) -> Result<(), CliError> {
        self.write_with(name, |file| {
            file.write_all(bytes).context(|| format!("writing {name}"))
        })
    }

    /// Writes the file `name` of the output folder through `fill`, which streams its contents into
    /// a buffered writer of the temporary file (so a long file is never held in memory), renamed
    /// into place at [`commit`](Self::commit). `name` is a plain file name: at most 120 bytes of
    /// ASCII letters, digits, `_`, `-` and `.`, not starting with `.`, written once per command.
    ///
    /// # Errors
    /// No output folder, a bad or repeated name, or a failed write or `fill` (the temporary is
    /// removed).
    pub fn write_with(
        &mut self,
        name: &str,
        fill: impl FnOnce(&mut dyn Write) -> Result<(), CliError>,
    ) -> Result<(), CliError> {
        let Some(dir) = &self.dir else {
            return Err(format!("internal: {name} written without an output folder").into());
        };
        check_name(name)?;
        let target = dir.join(name);
        if self.pending.iter().any(|(_, t)| *t == target) {
            return Err(format!(
                "internal: {name} written twice by one command (two tables of the same name?)"
            )
            .into());
        }
        if is_folder(&target) {
            return Err(in_the_way(&target));
        }
        let temporary = dir.join(format!(".{name}.{}.tmp", std::process::id()));
        let writing = || format!("writing {}", target.display());
        let created = {
            let mut staged = staged();
            let created = fs::File::create(&temporary).context(writing);
            if created.is_ok() {
                staged.push(temporary.clone());
            }
            created
        };
        let written = created.and_then(|file| {
            let mut buffered = BufWriter::new(file);
            fill(&mut buffered)?;
            let file = buffered
                .into_inner()
                .map_err(std::io::IntoInnerError::into_error)
                .context(writing)?;
            file.sync_all().context(writing)
        });
        if let Err(e) = written {
            remove(&temporary);
            return Err(e);
        }
        self.pending.push((temporary, target));
        Ok(())
    }

    /// Renames every pending file into place, in the order written, and returns their paths. Each
    /// rename is atomic, so a reader sees a file whole or its earlier version, never half of one.
    /// Every target is checked first (a folder in a file's place would fail its rename halfway
    /// through), and the renames run under one hold of the staging lock, so that a signal waits
    /// for the commit to end instead of leaving old and new files mixed.
    ///
    /// # Errors
    /// A target that is a folder (nothing renamed, every temporary removed), or a rename that
    /// fails (the files not yet renamed are removed; those before it are in place).
    pub fn commit(mut self) -> Result<Vec<PathBuf>, CliError> {
        if let Some((_, target)) = self.pending.iter().find(|(_, t)| is_folder(t)) {
            return Err(in_the_way(target));
        }
        let pending = std::mem::take(&mut self.pending);
        self.created = false;
        let mut staged = staged();
        let mut done = Vec::with_capacity(pending.len());
        let mut rest = pending.into_iter();
        for (temporary, target) in rest.by_ref() {
            let renamed = fs::rename(&temporary, &target);
            if renamed.is_err() {
                let _ = fs::remove_file(&temporary);
            }
            unstage(&mut staged, &temporary);
            if let Err(e) = renamed {
                drop(staged);
                self.pending = rest.collect();
                return Err(format!(
                    "moving {} into place: {e} ({} of the command's files were already in place)",
                    target.display(),
                    done.len()
                )
                .into());
            }
            done.push(target);
        }
        Ok(done)
    }

    /// [`commit`](Self::commit)s the files and says where they went.
    ///
    /// # Errors
    /// As [`commit`](Self::commit).
    pub fn finish(self) -> Result<(), CliError> {
        let dir = self.dir().map(|d| d.display().to_string());
        let written = self.commit()?;
        if let Some(dir) = dir {
            crate::report::print(&format!("wrote {} files into {dir}", written.len()));
        }
        Ok(())
    }
}

impl Drop for Output {
    /// Removes the temporaries of an uncommitted output, and the folder if it created it and it
    /// is empty: a failed command leaves nothing behind.
    fn drop(&mut self) {
        for (temporary, _) in &self.pending {
            remove(temporary);
        }
        if let (true, Some(dir)) = (self.created, &self.dir) {
            // Only an empty folder is removed: anything else put there stays.
            let _ = fs::remove_dir(dir);
        }
    }
}

/// Whether a folder (not a link to one: a rename replaces the link) stands where `target` goes.
fn is_folder(target: &Path) -> bool {
    fs::symlink_metadata(target).is_ok_and(|m| m.is_dir())
}

/// The error for a folder standing where a file goes.
fn in_the_way(target: &Path) -> CliError {
    format!(
        "{} is a folder where the command writes a file: move it or choose another --out",
        target.display()
    )
    .into()
}

/// Removes a staged temporary and drops it from the staged list.
fn remove(temporary: &Path) {
    let mut staged = staged();
    let _ = fs::remove_file(temporary);
    unstage(&mut staged, temporary);
}

/// Refuses names that are not plain, portable file names (see [`Output::write`]).
///
/// # Errors
/// The name and the rule it breaks.
pub fn check_name(name: &str) -> Result<(), CliError> {
    let plain = name
        .bytes()
        .all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-' || b == b'.');
    if name.is_empty() || name.len() > MAX_NAME || name.starts_with('.') || !plain {
        return Err(format!(
            "file name {name:?} is not a plain name (1 to {MAX_NAME} ASCII letters, digits, '_', '-' or \
             '.', not starting with '.')"
        ).into());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh, empty folder for one test.
    fn folder(test: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("liebayes-output-{test}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        dir
    }

    fn files(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    fn args(dir: &Path) -> OutputArgs {
        OutputArgs {
            out: Some(dir.to_path_buf()),
            shard: Shard::WHOLE,
        }
    }

    #[test]
    fn nothing_is_visible_before_the_commit_and_everything_after() {
        let dir = folder("commit");
        let mut output = prepare(&args(&dir)).unwrap();
        output.write("a.csv", b"1\n").unwrap();
        output.write("b.svg", b"<svg/>").unwrap();
        assert!(!dir.join("a.csv").exists() && !dir.join("b.svg").exists());
        let written = output.commit().unwrap();
        assert_eq!(written, vec![dir.join("a.csv"), dir.join("b.svg")]);
        assert_eq!(files(&dir), ["a.csv", "b.svg"]);
        assert_eq!(fs::read(dir.join("a.csv")).unwrap(), b"1\n");
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_failing_write_leaves_no_file_and_keeps_the_earlier_ones() {
        let dir = folder("failing");
        fs::create_dir_all(&dir).unwrap();
        fs::write(dir.join("a.csv"), b"earlier").unwrap();
        let mut output = prepare(&args(&dir)).unwrap();
        output.write("a.csv", b"new").unwrap();
        // A folder of that temporary name makes the write fail.
        fs::create_dir(dir.join(format!(".b.csv.{}.tmp", std::process::id()))).unwrap();
        assert!(output.write("b.csv", b"x").is_err());
        assert!(output.write("../escape", b"x").is_err());
        assert!(output.write("a.csv", b"twice").is_err());
        drop(output);
        fs::remove_dir(dir.join(format!(".b.csv.{}.tmp", std::process::id()))).unwrap();
        assert_eq!(files(&dir), ["a.csv"]);
        assert_eq!(fs::read(dir.join("a.csv")).unwrap(), b"earlier");
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_folder_in_a_files_place_fails_before_anything_is_renamed() {
        let dir = folder("in-the-way");
        fs::create_dir_all(dir.join("b.csv")).unwrap();
        fs::write(dir.join("a.csv"), b"earlier").unwrap();
        let mut output = prepare(&args(&dir)).unwrap();
        let error = output.write("b.csv", b"new").unwrap_err();
        assert!(error.to_string().contains("is a folder"), "{error}");
        // A folder that appears after its file was staged: the commit renames nothing.
        output.write("a.csv", b"new").unwrap();
        output.write("c.csv", b"new").unwrap();
        fs::create_dir_all(dir.join("c.csv")).unwrap();
        let error = output.commit().unwrap_err();
        assert!(error.to_string().contains("c.csv is a folder"), "{error}");
        assert_eq!(files(&dir), ["a.csv", "b.csv", "c.csv"]);
        assert_eq!(fs::read(dir.join("a.csv")).unwrap(), b"earlier");
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_streamed_file_is_whole_or_absent() {
        let dir = folder("streamed");
        let mut output = prepare(&args(&dir)).unwrap();
        output
            .write_with("long.csv", |file| {
                for k in 0..100_000 {
                    writeln!(file, "{k}")?;
                }
                Ok(())
            })
            .unwrap();
        let error = output
            .write_with("failed.csv", |file| {
                writeln!(file, "a first line")?;
                Err("the run failed".to_owned().into())
            })
            .unwrap_err();
        assert_eq!(error.to_string(), "the run failed");
        // The failed file's temporary is gone at once, the streamed one waits for the commit.
        assert_eq!(
            files(&dir),
            [format!(".long.csv.{}.tmp", std::process::id())]
        );
        output.commit().unwrap();
        assert_eq!(files(&dir), ["long.csv"]);
        let text = fs::read_to_string(dir.join("long.csv")).unwrap();
        assert_eq!(text.lines().count(), 100_000);
        assert_eq!(text.lines().last(), Some("99999"));
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn the_folder_is_checked_before_any_work() {
        let dir = folder("checked");
        fs::create_dir_all(&dir).unwrap();
        fs::write(dir.join("file"), b"").unwrap();
        let error = prepare(&args(&dir.join("file").join("below"))).unwrap_err();
        assert!(
            error
                .to_string()
                .contains("cannot create the output folder"),
            "{error}"
        );
        let partial = OutputArgs {
            out: None,
            shard: Shard::new(2, 3).unwrap(),
        };
        assert!(
            prepare(&partial)
                .unwrap_err()
                .to_string()
                .contains("--shard 2/3 needs --out")
        );
        let mut none = prepare(&OutputArgs {
            out: None,
            shard: Shard::WHOLE,
        })
        .unwrap();
        assert!(none.dir().is_none() && none.write("a.csv", b"").is_err());
        assert_eq!(files(&dir), ["file"]);
        fs::remove_dir_all(&dir).unwrap();
    }
}
