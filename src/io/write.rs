//! File output that never leaves a half-written file behind, and a command's outputs that
//! appear together or not at all ([`all_or_nothing`]).

use crate::error::{Error, Result};
use std::cell::RefCell;
use std::io::Write;
use std::path::{Path, PathBuf};

/// A write waiting for its transaction: the complete temporary file beside its destination
/// (or, for a stream, in the system's temporary folder).
struct Staged {
    path: PathBuf,
    target: Target,
    tmp: tempfile::NamedTempFile,
}

/// Where the bytes written to a path land.
#[derive(Clone, Debug, PartialEq)]
enum Target {
    /// A file replaced by a rename: the path itself, or the file its symbolic links lead to
    /// (the links stay links).
    File(PathBuf),
    /// A device, a FIFO or a socket (`/dev/null`, a pipe), or this process's standard
    /// output or error (which, when it is one of them: written through its handle): written
    /// in place, at the end of the command, as a stream. A rename there would put a plain
    /// file where the device or the link was.
    Stream(Option<Standard>),
}

/// The most symbolic links followed before a path is taken as it is (Linux's own limit).
const MAX_LINKS: usize = 40;

/// Where writing to `path` lands ([`Target`]). Symbolic links are followed by hand, so that
/// one naming a file that does not exist yet is written through too; a path in `/proc` or
/// `/dev/fd`, or a link into them (`/dev/stdout`), names an open stream. A loop of links is
/// an error.
fn target_of(path: &Path) -> std::io::Result<Target> {
    let open_stream = |p: &Path| p.starts_with("/proc") || p.starts_with("/dev/fd");
    // Through the links, as opening the path would go.
    let stream = || {
        Target::Stream(
            std::fs::metadata(path)
                .ok()
                .and_then(|m| standard_stream(&m)),
        )
    };
    let mut p = path.to_path_buf();
    let mut links = 0;
    while let Ok(link) = std::fs::read_link(&p) {
        if open_stream(&p) {
            return Ok(stream());
        }
        links += 1;
        if links > MAX_LINKS {
            return Err(std::io::Error::other(format!(
                "more than {MAX_LINKS} symbolic links in a row (a loop?)"
            )));
        }
        p = match p.parent() {
            Some(dir) if link.is_relative() => dir.join(link),
            _ => link,
        };
    }
    if open_stream(&p) {
        return Ok(stream());
    }
    Ok(match std::fs::metadata(&p) {
        Ok(m) if m.is_dir() => Target::File(p),
        Ok(m) if !m.is_file() || standard_stream(&m).is_some() => {
            Target::Stream(standard_stream(&m))
        }
        _ => Target::File(p),
    })
}

/// The file a write to `path` replaces, through its symbolic links (also a file not there
/// yet); None for a stream (a device, a pipe, this process's standard output) or a loop of
/// links. Two outputs with the same target would overwrite one another.
pub fn output_file(path: &Path) -> Option<PathBuf> {
    match target_of(path) {
        Ok(Target::File(p)) => Some(p),
        _ => None,
    }
}

/// Whether writing to `path` lands in this process's standard output (`/dev/stdout`, or the
/// file a shell's `>` sent it to) and stays there: a file, a pipe or a terminal, not a
/// device that discards what it gets (`--out /dev/null > /dev/null`).
pub fn is_standard_output(path: &Path) -> bool {
    use std::io::IsTerminal;
    #[cfg(unix)]
    let sink = || {
        use std::os::fd::AsFd;
        use std::os::unix::fs::FileTypeExt;
        let device =
            metadata_of(std::io::stdout().as_fd()).is_some_and(|m| m.file_type().is_char_device());
        device && !std::io::stdout().is_terminal()
    };
    #[cfg(not(unix))]
    let sink = || false;
    matches!(target_of(path), Ok(Target::Stream(Some(Standard::Out)))) && !sink()
}

/// The metadata of the file behind an open descriptor (one of this process's standard
/// streams), if it can be read.
#[cfg(unix)]
fn metadata_of(fd: std::os::fd::BorrowedFd) -> Option<std::fs::Metadata> {
    fd.try_clone_to_owned()
        .ok()
        .and_then(|fd| std::fs::File::from(fd).metadata().ok())
}

/// This process's standard output or error.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(not(unix), allow(dead_code))]
enum Standard {
    Out,
    Err,
}

/// Which of this process's standard output and error `m` is the file behind, if either (a
/// shell's `> file` given as `--out` too: a rename would leave the process writing to a
/// deleted file).
#[cfg(unix)]
fn standard_stream(m: &std::fs::Metadata) -> Option<Standard> {
    use std::os::fd::AsFd;
    use std::os::unix::fs::MetadataExt;
    let same = |fd: std::os::fd::BorrowedFd| {
        metadata_of(fd).is_some_and(|s| s.dev() == m.dev() && s.ino() == m.ino())
    };
    if same(std::io::stdout().as_fd()) {
        Some(Standard::Out)
    } else if same(std::io::stderr().as_fd()) {
        Some(Standard::Err)
    } else {
        None
    }
}

#[cfg(not(unix))]
fn standard_stream(_: &std::fs::Metadata) -> Option<Standard> {
    None
}

/// Puts a finished temporary file where it belongs: renamed over a file, or copied into a
/// stream: this process's own standard output or error through their handles (after the
/// text the command printed before it), any other stream opened for appending.
fn deliver(path: &Path, target: &Target, tmp: tempfile::NamedTempFile) -> Result<()> {
    let name = tmp.path().to_path_buf();
    match target {
        // The rename and the file's leaving the pending list are one step for an interrupt
        // ([`discard_pending`]): it deletes the temporary file before, or finds it gone.
        // Dropped on failure: the temporary file is deleted.
        Target::File(to) => pending(|p| {
            let renamed = tmp.persist(to);
            p.files.retain(|f| *f != name);
            renamed
                .map(|_| ())
                .map_err(|e| Error::io(path, bare(e.error)))
        }),
        // A copy into a stream may wait on a full pipe: not while holding the list.
        Target::Stream(standard) => {
            let copied = write_stream(path, *standard, &tmp);
            drop(tmp);
            settled(&name);
            copied
        }
    }
}

/// [`deliver`] into a stream, copied from the temporary file (a million rows need no memory).
fn write_stream(
    path: &Path,
    standard: Option<Standard>,
    tmp: &tempfile::NamedTempFile,
) -> Result<()> {
    let mut from = tmp.reopen().map_err(|e| Error::io(path, e))?;
    let mut copy = |to: &mut dyn Write| std::io::copy(&mut from, to).and_then(|_| to.flush());
    let written = match standard {
        Some(Standard::Out) => copy(&mut std::io::stdout().lock()),
        Some(Standard::Err) => copy(&mut std::io::stderr().lock()),
        None => std::fs::OpenOptions::new()
            .append(true)
            .open(path)
            .and_then(|mut f| copy(&mut f)),
    };
    written.map_err(|e| Error::io(path, e))
}

/// The open transaction of this thread: its staged writes and the folders it created.
#[derive(Default)]
struct Transaction {
    writes: Vec<Staged>,
    dirs: Vec<PathBuf>,
}

impl Transaction {
    /// Deletes the staged temporary files and removes the folders made, when empty.
    fn discard(self) {
        let names: Vec<PathBuf> = (self.writes.iter())
            .map(|w| w.tmp.path().to_path_buf())
            .collect();
        drop(self.writes);
        pending(|p| p.files.retain(|f| !names.contains(f)));
        remove_empty_dirs(self.dirs);
    }
}

/// Every temporary file not yet renamed into place or deleted, and every folder an open
/// transaction made, across threads: what [`discard_pending`] removes when the process is
/// interrupted (a signal ends it without unwinding, so no destructor runs).
#[derive(Default)]
struct Pending {
    files: Vec<PathBuf>,
    dirs: Vec<PathBuf>,
}

static PENDING: std::sync::Mutex<Pending> = std::sync::Mutex::new(Pending {
    files: Vec::new(),
    dirs: Vec::new(),
});

/// The pending list, locked (also after a thread panicked holding it: the list stays a list
/// of paths).
fn lock_pending() -> std::sync::MutexGuard<'static, Pending> {
    PENDING
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Runs `f` on the pending list, locked.
fn pending<T>(f: impl FnOnce(&mut Pending) -> T) -> T {
    f(&mut lock_pending())
}

/// A temporary file no longer pending: renamed into place or deleted.
fn settled(tmp: &Path) {
    pending(|p| p.files.retain(|f| f != tmp));
}

/// The pending list held by [`discard_pending`]: until it is dropped, no temporary file is
/// made or renamed into place and no folder made, in any thread.
pub struct PendingHeld(#[allow(dead_code)] std::sync::MutexGuard<'static, Pending>);

/// Deletes every temporary file this process has not yet renamed into place and removes the
/// folders its open transactions made (when empty): for a process about to end on a signal
/// (Ctrl-C), whose destructors will not run. What is already in place stays. The list stays
/// held (the result) for the caller to end the process with: a write under way in another
/// thread then waits, and puts nothing in place after the clean-up.
pub fn discard_pending() -> PendingHeld {
    let mut held = lock_pending();
    for f in std::mem::take(&mut held.files) {
        let _ = std::fs::remove_file(f);
    }
    remove_empty_dirs(std::mem::take(&mut held.dirs));
    PendingHeld(held)
}

/// Removes the folders of `dirs` that are empty, deepest first (a folder's subfolders, made
/// by a later call, go before it).
fn remove_empty_dirs(mut dirs: Vec<PathBuf>) {
    dirs.sort_by_key(|d| std::cmp::Reverse(d.components().count()));
    for d in &dirs {
        let _ = std::fs::remove_dir(d);
    }
}

thread_local! {
    static OPEN: RefCell<Option<Transaction>> = const { RefCell::new(None) };
    static DISCARDED: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
    static KEPT: RefCell<Vec<PathBuf>> = const { RefCell::new(Vec::new()) };
}

/// The outputs the last [`all_or_nothing`] had put in place before one of its streams failed
/// (a full device, a closed pipe): complete files, kept (empty after a success or an earlier
/// failure, which keeps none).
pub fn kept_outputs() -> Vec<PathBuf> {
    KEPT.with_borrow(Clone::clone)
}

/// The number of output files the last failed [`all_or_nothing`] had prepared and discarded
/// (0 after a success): what a command announced as written before it failed was not kept.
pub fn discarded_outputs() -> usize {
    DISCARDED.get()
}

/// Writes `bytes` to `path` through a temporary file in the same folder and a rename, so that
/// a reader sees either the old file or the whole new one. Inside [`all_or_nothing`] the
/// rename waits for the transaction's end (a later write of the same path replaces it).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let mut w = AtomicWriter::create(path)?;
    w.write_all(bytes).map_err(|e| Error::io(path, bare(e)))?;
    w.finish()
}

/// A file written piece by piece (rows streamed, nothing held in memory) that appears only
/// on [`AtomicWriter::finish`], as [`write_atomic`]'s does; dropped unfinished, it leaves
/// nothing.
pub struct AtomicWriter {
    path: PathBuf,
    target: Target,
    /// None once finished (then staged or delivered).
    out: Option<std::io::BufWriter<tempfile::NamedTempFile>>,
    /// The temporary file's path, taken off the pending list when it is dropped unfinished.
    tmp_name: PathBuf,
}

impl AtomicWriter {
    /// A temporary file beside `path` (beside the file its links lead to; for a stream, in
    /// the system's temporary folder).
    pub fn create(path: &Path) -> Result<AtomicWriter> {
        let target = target_of(path).map_err(|e| Error::io(path, e))?;
        let temp = std::env::temp_dir();
        let dir = match &target {
            Target::Stream(_) => temp.as_path(),
            Target::File(to) => match to.parent() {
                Some(p) if !p.as_os_str().is_empty() => p,
                _ => Path::new("."),
            },
        };
        let tmp = temporary_in(dir, path).map_err(|e| Error::io(path, bare(e)))?;
        Ok(AtomicWriter {
            path: path.to_path_buf(),
            target,
            tmp_name: tmp.path().to_path_buf(),
            out: Some(std::io::BufWriter::new(tmp)),
        })
    }

    /// The destination.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Flushes and renames the file into place, or copies it into a stream (or stages it for
    /// the open transaction).
    pub fn finish(mut self) -> Result<()> {
        let path = self.path.clone();
        let target = self.target.clone();
        // Dropped on a failure below, the temporary file is deleted and `self`'s drop takes
        // it off the pending list; from here on it is staged or delivered instead.
        let Some(out) = self.out.take() else {
            return Ok(());
        };
        let failed = |e: std::io::Error| {
            settled(&self.tmp_name);
            Error::io(&path, bare(e))
        };
        let tmp = out.into_inner().map_err(|e| failed(e.into_error()))?;
        if let Err(e) = tmp.as_file().sync_all() {
            drop(tmp);
            return Err(failed(e));
        }
        let staged = OPEN.with_borrow_mut(|open| match open {
            Some(t) => {
                // A later write of the same path replaces the staged one (deleted here).
                if let Some(k) = t.writes.iter().position(|w| w.path == path) {
                    let replaced = t.writes.remove(k);
                    let name = replaced.tmp.path().to_path_buf();
                    drop(replaced);
                    settled(&name);
                }
                t.writes.push(Staged {
                    path: path.clone(),
                    target: target.clone(),
                    tmp,
                });
                None
            }
            None => Some(tmp),
        });
        match staged {
            Some(tmp) => deliver(&path, &target, tmp),
            None => Ok(()),
        }
    }
}

impl Drop for AtomicWriter {
    /// Unfinished, the temporary file is deleted (tempfile's own drop) and leaves the list.
    fn drop(&mut self) {
        if let Some(out) = self.out.take() {
            drop(out);
            settled(&self.tmp_name);
        }
    }
}

impl AtomicWriter {
    /// The open temporary file (an error once finished, which `finish` taking `self` rules
    /// out).
    fn out(&mut self) -> std::io::Result<&mut std::io::BufWriter<tempfile::NamedTempFile>> {
        self.out
            .as_mut()
            .ok_or_else(|| std::io::Error::other("the file is finished"))
    }
}

impl Write for AtomicWriter {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.out()?.write(buf)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.out()?.flush()
    }
}

/// A temporary file in `dir` for `path`: with the mode of the file it replaces, else the
/// mode a plain create gives (0666 less the umask); tempfile's own default is 0600.
fn temporary_in(dir: &Path, path: &Path) -> std::io::Result<tempfile::NamedTempFile> {
    let mut b = tempfile::Builder::new();
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(path).map_or(0o666, |m| m.permissions().mode() & 0o7777);
        b.permissions(std::fs::Permissions::from_mode(mode));
    }
    // Made and listed in one step for an interrupt ([`discard_pending`]).
    pending(|p| {
        let tmp = b.tempfile_in(dir)?;
        p.files.push(tmp.path().to_path_buf());
        Ok(tmp)
    })
}

/// The OS error without the temporary file's name that `tempfile` wraps around it: the
/// destination is named once, by [`Error::io`].
fn bare(e: std::io::Error) -> std::io::Error {
    // tempfile's wrapper keeps the OS error only in its text: "... (os error N) at path P".
    let code = e.raw_os_error().or_else(|| {
        let text = e.get_ref()?.to_string();
        let at = text.find("(os error ")? + "(os error ".len();
        text[at..].split(')').next()?.parse().ok()
    });
    match code {
        Some(c) => std::io::Error::from_raw_os_error(c),
        None => std::io::Error::new(e.kind(), e.kind().to_string()),
    }
}

/// The bytes the open transaction will write to `path`, if it staged any: a read-modify-write
/// (a folder's figure list) sees the transaction's own earlier writes.
pub fn staged_bytes(path: &Path) -> Option<Vec<u8>> {
    OPEN.with_borrow(|open| {
        let w = open.as_ref()?.writes.iter().find(|w| w.path == path)?;
        std::fs::read(w.tmp.path()).ok()
    })
}

/// Creates `dir` and its missing parents; inside [`all_or_nothing`] the folders created are
/// removed again (when empty) if the transaction fails.
pub fn create_dir_all(dir: &Path) -> Result<()> {
    let mut missing = Vec::new();
    let mut d = Some(dir);
    while let Some(p) = d {
        if p.as_os_str().is_empty() || p.exists() {
            break;
        }
        missing.push(p.to_path_buf());
        d = p.parent();
    }
    let open = OPEN.with_borrow(Option::is_some);
    // Made and listed in one step for an interrupt ([`discard_pending`]).
    pending(|p| {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        if open {
            p.dirs.extend(missing.iter().cloned());
        }
        Ok::<(), Error>(())
    })?;
    OPEN.with_borrow_mut(|open| {
        if let Some(t) = open {
            t.dirs.extend(missing);
        }
    });
    Ok(())
}

/// Ends this thread's open transaction without its outputs, for a process about to exit
/// without unwinding (a closed pipe met in a panic hook): its temporary files are deleted and
/// the folders it made removed when empty, as a failed [`all_or_nothing`] does. Nothing where
/// no transaction is open (or its state is in use).
pub fn abandon() {
    let _ = OPEN.try_with(|open| {
        if let Ok(mut open) = open.try_borrow_mut()
            && let Some(t) = open.take()
        {
            t.discard();
        }
    });
}

/// Runs `f` as one transaction: every [`write_atomic`] inside it is renamed into place only
/// when `f` succeeds, so a command's outputs appear together or not at all. On failure the
/// temporary files are deleted and the folders [`create_dir_all`] made are removed when empty.
/// Nested calls join the outer transaction.
pub fn all_or_nothing<T, E: From<Error>>(
    f: impl FnOnce() -> std::result::Result<T, E>,
) -> std::result::Result<T, E> {
    if OPEN.with_borrow(|open| open.is_some()) {
        return f();
    }
    OPEN.set(Some(Transaction::default()));
    let result = f();
    let t = OPEN.take().unwrap_or_default();
    // The folders made stay on the pending list until the files are in them (an interrupt
    // before then removes them), then leave it: kept on success, removed by `discard` on
    // failure.
    let made = t.dirs.clone();
    let unlist = || pending(|p| p.dirs.retain(|d| !made.contains(d)));
    // A destination that cannot take a file fails before any rename, not halfway.
    let result = match result {
        Ok(v) => match destinations_ready(&t.writes) {
            Ok(()) => Ok(v),
            Err(e) => Err(E::from(e)),
        },
        r => r,
    };
    DISCARDED.set(if result.is_err() { t.writes.len() } else { 0 });
    KEPT.set(Vec::new());
    match result {
        Ok(v) => {
            // Files first, streams last: a stream that fails (a closed pipe, a full device)
            // fails after every file is in place, and its error names it; what was put in
            // place before it is told ([`kept_outputs`]), the rest discarded.
            let (streams, files): (Vec<Staged>, Vec<Staged>) =
                (t.writes.into_iter()).partition(|w| matches!(w.target, Target::Stream(_)));
            let all: Vec<Staged> = files.into_iter().chain(streams).collect();
            let total = all.len();
            let mut kept = Vec::new();
            let mut all = all.into_iter();
            while let Some(w) = all.next() {
                if let Err(e) = deliver(&w.path, &w.target, w.tmp) {
                    DISCARDED.set(total - kept.len() - 1);
                    KEPT.set(kept);
                    Transaction {
                        writes: all.collect(),
                        dirs: Vec::new(),
                    }
                    .discard();
                    unlist();
                    return Err(E::from(e));
                }
                kept.push(w.path);
            }
            unlist();
            Ok(v)
        }
        Err(e) => {
            unlist();
            t.discard();
            Err(e)
        }
    }
}

/// Checks that every destination of `writes` can take its file: not a folder, and, where
/// no file is there yet, a name the file system accepts in a folder it may write (probed by
/// creating the file empty and removing it): a name too long or a read-only folder fails
/// here, before any output is renamed into place.
fn destinations_ready(writes: &[Staged]) -> Result<()> {
    for w in writes {
        // A stream exists and takes what it is given.
        let Target::File(to) = &w.target else {
            continue;
        };
        if to.is_dir() {
            return Err(Error::io(
                &w.path,
                std::io::Error::new(std::io::ErrorKind::IsADirectory, "is a folder"),
            ));
        }
        if !to.exists() {
            // Under the pending list's lock: an interrupt's clean-up, which ends the process
            // holding it, never falls between the probe's create and remove (an empty file
            // at the output's name).
            pending(|_| {
                match std::fs::OpenOptions::new()
                    .write(true)
                    .create_new(true)
                    .open(to)
                {
                    Ok(_) => {
                        let _ = std::fs::remove_file(to);
                        Ok(())
                    }
                    // Another writer made it meanwhile: the name is one the folder takes.
                    Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => Ok(()),
                    Err(e) => Err(Error::io(&w.path, e)),
                }
            })?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod transaction_tests {
    use super::*;

    #[test]
    fn writes_appear_at_the_end_or_never() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a.txt"), dir.path().join("new/b.txt"));
        let r: Result<()> = all_or_nothing(|| {
            write_atomic(&a, b"one")?;
            assert!(!a.exists(), "renamed before the end");
            assert_eq!(staged_bytes(&a).unwrap(), b"one");
            write_atomic(&a, b"two")?;
            create_dir_all(b.parent().unwrap())?;
            write_atomic(&b, b"three")
        });
        r.unwrap();
        assert_eq!(std::fs::read(&a).unwrap(), b"two");
        assert_eq!(std::fs::read(&b).unwrap(), b"three");
        let (c, d) = (dir.path().join("c.txt"), dir.path().join("x/y"));
        let r: Result<()> = all_or_nothing(|| {
            write_atomic(&c, b"lost")?;
            create_dir_all(&d)?;
            Err(Error::Invalid("a later step fails".into()))
        });
        assert!(r.is_err());
        assert!(!c.exists() && !dir.path().join("x").exists());
        // Only the destinations remain: no temporary file is left in the folder.
        let mut names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        names.sort();
        assert_eq!(names, ["a.txt", "new"]);
    }
}

#[cfg(all(test, unix))]
mod mode_tests {
    use super::write_atomic;
    use std::os::unix::fs::PermissionsExt;

    #[test]
    fn new_files_follow_the_umask_and_replaced_files_keep_their_mode() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a.txt"), dir.path().join("b.txt"));
        // What a plain create gives under this process's umask.
        std::fs::write(&b, "x").unwrap();
        let plain = std::fs::metadata(&b).unwrap().permissions().mode() & 0o777;
        std::fs::remove_file(&b).unwrap();
        write_atomic(&a, b"one").unwrap();
        let mode = |p: &std::path::Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode(&a), plain);
        std::fs::set_permissions(&a, std::fs::Permissions::from_mode(0o640)).unwrap();
        write_atomic(&a, b"two").unwrap();
        assert_eq!(mode(&a), 0o640);
    }
}

#[cfg(all(test, unix))]
mod link_tests {
    use super::{Result, all_or_nothing, write_atomic};
    use std::os::unix::fs::FileTypeExt;

    #[test]
    fn links_are_written_through_and_stay_links() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("real")).unwrap();
        let (file, link) = (dir.path().join("real/a.csv"), dir.path().join("a.csv"));
        std::fs::write(&file, "old").unwrap();
        std::os::unix::fs::symlink("real/a.csv", &link).unwrap();
        write_atomic(&link, b"new").unwrap();
        assert!(std::fs::symlink_metadata(&link).unwrap().is_symlink());
        assert_eq!(std::fs::read(&file).unwrap(), b"new");
        // A link to a file not there yet (and a link to that link), in a transaction.
        let (second, chain) = (dir.path().join("b.csv"), dir.path().join("c.csv"));
        std::os::unix::fs::symlink(dir.path().join("real/b.csv"), &second).unwrap();
        std::os::unix::fs::symlink("b.csv", &chain).unwrap();
        let r: Result<()> = all_or_nothing(|| write_atomic(&chain, b"made"));
        r.unwrap();
        assert!(std::fs::symlink_metadata(&second).unwrap().is_symlink());
        assert!(std::fs::symlink_metadata(&chain).unwrap().is_symlink());
        assert_eq!(
            std::fs::read(dir.path().join("real/b.csv")).unwrap(),
            b"made"
        );
        // No temporary file is left beside the links or their files.
        let count = |d: &std::path::Path| std::fs::read_dir(d).unwrap().count();
        assert_eq!((count(dir.path()), count(&dir.path().join("real"))), (4, 2));
    }

    #[test]
    fn a_loop_of_links_is_an_error_naming_the_path() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a"), dir.path().join("b"));
        std::os::unix::fs::symlink("b", &a).unwrap();
        std::os::unix::fs::symlink("a", &b).unwrap();
        let e = write_atomic(&a, b"x").unwrap_err().to_string();
        assert!(
            e.contains("symbolic links") && e.contains(&*a.to_string_lossy()),
            "{e}"
        );
        assert!(std::fs::symlink_metadata(&a).unwrap().is_symlink());
        assert!(std::fs::symlink_metadata(&b).unwrap().is_symlink());
    }

    #[test]
    fn a_fifo_is_written_into_not_replaced() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("pipe");
        let made = std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .expect("mkfifo runs");
        assert!(made.success());
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || std::fs::read(fifo).unwrap())
        };
        let r: Result<()> = all_or_nothing(|| write_atomic(&fifo, b"through the pipe\n"));
        r.unwrap();
        // Checked before joining: had the pipe been replaced, its reader would wait forever.
        let kind = std::fs::symlink_metadata(&fifo).unwrap().file_type();
        assert!(kind.is_fifo(), "{kind:?}");
        assert_eq!(reader.join().unwrap(), b"through the pipe\n");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }
}
