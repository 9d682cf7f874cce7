//! File-system helpers below every other module: writing an output file so
//! that it appears completely or not at all, and reading an input file up to
//! a size limit (an endless input such as `/dev/zero` is refused once it
//! passes the limit, not read until memory runs out).

use crate::error::{Error, Result};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

/// Reads at most `limit` bytes of `path`; a longer file (or an endless
/// stream) is an error naming it, what it is (`what`, e.g. "map") and the
/// limit. A regular file's size is checked before reading.
pub fn read_limited(path: &Path, limit: u64, what: &str) -> Result<Vec<u8>> {
    let too_big = || {
        Error::format(
            path,
            format!(
                "the {what} is larger than the limit of {} ({limit} bytes)",
                human_bytes(limit)
            ),
        )
    };
    let f = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    if let Ok(m) = f.metadata() {
        if m.is_file() && m.len() > limit {
            return Err(too_big());
        }
    }
    read_to_limit(f, limit, path).and_then(|b| {
        if b.len() as u64 > limit {
            Err(too_big())
        } else {
            Ok(b)
        }
    })
}

/// Up to `limit + 1` bytes of `r` (one more than allowed tells "too long").
fn read_to_limit(r: impl Read, limit: u64, path: &Path) -> Result<Vec<u8>> {
    let mut bytes = Vec::new();
    r.take(limit.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(|e| Error::io(path, e))?;
    Ok(bytes)
}

/// [`read_limited`] as UTF-8 text.
pub fn read_text_limited(path: &Path, limit: u64, what: &str) -> Result<String> {
    let bytes = read_limited(path, limit, what)?;
    String::from_utf8(bytes).map_err(|e| {
        Error::format(
            path,
            format!(
                "the {what} is not UTF-8 text (invalid byte at offset {})",
                e.utf8_error().valid_up_to()
            ),
        )
    })
}

/// The first `n` bytes of `path` (fewer if it is shorter): to recognise a
/// format before reading a whole file.
pub fn read_head(path: &Path, n: u64) -> Result<Vec<u8>> {
    let f = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut bytes = Vec::new();
    f.take(n)
        .read_to_end(&mut bytes)
        .map_err(|e| Error::io(path, e))?;
    Ok(bytes)
}

/// A byte count for people: "16 MiB", "1 GiB".
pub fn human_bytes(n: u64) -> String {
    const UNITS: [(u64, &str); 3] = [(1 << 30, "GiB"), (1 << 20, "MiB"), (1 << 10, "KiB")];
    for (size, unit) in UNITS {
        if n >= size {
            let x = n as f64 / size as f64;
            return if x.fract() == 0.0 {
                format!("{x:.0} {unit}")
            } else {
                format!("{x:.1} {unit}")
            };
        }
    }
    format!("{n} bytes")
}

/// Temporary files being written, removed by [`remove_temporaries`] (the
/// binary calls it on SIGINT and SIGTERM).
/// After [`remove_temporaries`], no new one is started (`true`).
static PENDING: std::sync::Mutex<(Vec<PathBuf>, bool)> = std::sync::Mutex::new((Vec::new(), false));

fn pending() -> std::sync::MutexGuard<'static, (Vec<PathBuf>, bool)> {
    PENDING.lock().unwrap_or_else(|e| e.into_inner())
}

/// Removes every temporary file an [`AtomicFile`] (or [`write_atomic`]) is
/// writing at this moment, and refuses new ones: for a signal handler,
/// before the process exits.
pub fn remove_temporaries() {
    let mut p = pending();
    p.1 = true;
    for t in p.0.drain(..) {
        let _ = std::fs::remove_file(t);
    }
}

/// Whether [`remove_temporaries`] was called (the process is stopping on a
/// signal): an error that follows is the signal's doing.
pub fn stopping() -> bool {
    pending().1
}

/// Longest file name (bytes) the temporary files are given: `NAME_MAX` of
/// Linux's file systems (and of macOS's and Windows' in UTF-16 units).
const MAX_NAME_BYTES: usize = 255;

/// Temporary files started by this process, numbering them.
static STARTED: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// The hidden temporary name for an output named `name`: `.NAME.tmpPID-N`,
/// N counting this process's temporary files (so two files of one name, or
/// of two long names cut to the same start, never share one); `NAME` is cut
/// at a character boundary to keep the whole within [`MAX_NAME_BYTES`] (an
/// output named with 245 bytes or more could not be written otherwise).
fn temporary_name(name: &str) -> String {
    let suffix = format!(
        ".tmp{}-{}",
        std::process::id(),
        STARTED.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
    );
    let mut end = name.len().min(MAX_NAME_BYTES - 1 - suffix.len());
    while !name.is_char_boundary(end) {
        end -= 1;
    }
    format!(".{}{suffix}", &name[..end])
}

/// An output file written atomically: the bytes go to a hidden temporary
/// file beside `path` (`.NAME.tmpPID-N`, `temporary_name`), which [`AtomicFile::commit`] syncs
/// and renames into place. Dropped without a commit (an error, a panic), the
/// temporary file is removed and `path` is left as it was; the binary also
/// removes it on SIGINT and SIGTERM ([`remove_temporaries`]).
#[derive(Debug)]
pub struct AtomicFile {
    path: PathBuf,
    tmp: PathBuf,
    file: Option<std::io::BufWriter<std::fs::File>>,
}

impl AtomicFile {
    /// Starts writing `path` (its folder must exist).
    pub fn create(path: &Path) -> Result<AtomicFile> {
        let dir = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
        let name = path.file_name().ok_or_else(|| {
            Error::InvalidParameter(format!("{}: not a file path", path.display()))
        })?;
        // Refused here rather than at the rename, after other outputs of
        // an [`OutputSet`] may have replaced earlier files.
        if name.len() > MAX_NAME_BYTES {
            return Err(Error::io(
                path,
                std::io::Error::new(
                    std::io::ErrorKind::InvalidInput,
                    format!(
                        "the file name is {} bytes long, above the limit of {MAX_NAME_BYTES}",
                        name.len()
                    ),
                ),
            ));
        }
        let tmp = dir.join(temporary_name(&name.to_string_lossy()));
        // Created and registered under the lock, so that a signal handler's
        // [`remove_temporaries`] sees every temporary file there is.
        let file = {
            let mut p = pending();
            if p.1 {
                return Err(Error::io(
                    path,
                    std::io::Error::new(std::io::ErrorKind::Interrupted, "stopping on a signal"),
                ));
            }
            let f = std::fs::File::create(&tmp).map_err(|e| Error::io(path, e))?;
            p.0.push(tmp.clone());
            f
        };
        Ok(AtomicFile {
            path: path.to_path_buf(),
            tmp,
            file: Some(std::io::BufWriter::new(file)),
        })
    }

    /// Syncs the temporary file and renames it to the final path.
    pub fn commit(mut self) -> Result<()> {
        self.sync()?;
        self.rename() // on an error, Drop removes the temporary file
    }

    /// The final path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Flushes and syncs the temporary file (the first half of
    /// [`AtomicFile::commit`]: where a full disk shows).
    fn sync(&mut self) -> Result<()> {
        let file = self
            .file
            .as_mut()
            .expect("an uncommitted AtomicFile has its file");
        file.flush()
            .and_then(|()| file.get_ref().sync_all())
            .map_err(|e| Error::io(&self.path, e))
    }

    /// Renames the synced temporary file to the final path (the second
    /// half of [`AtomicFile::commit`]).
    fn rename(&mut self) -> Result<()> {
        std::fs::rename(&self.tmp, &self.path).map_err(|e| Error::io(&self.path, e))?;
        self.file = None;
        forget(&self.tmp);
        Ok(())
    }
}

/// A command's output files written all or none: each goes to its
/// [`AtomicFile`], and [`OutputSet::commit`] renames them into place only
/// once every one is complete. Dropped without a commit (an error in a later
/// step, a failed output), it removes every temporary file and every folder
/// it created, so a failed command leaves no new file behind.
#[derive(Debug, Default)]
pub struct OutputSet {
    files: Vec<AtomicFile>,
    /// Folders created for the outputs, outermost first.
    made_dirs: Vec<PathBuf>,
}

impl OutputSet {
    /// An empty set.
    pub fn new() -> OutputSet {
        OutputSet::default()
    }

    /// Starts writing `path`, creating its missing folders (removed again if
    /// the set is not committed); hand the file back with [`OutputSet::add`].
    pub fn create(&mut self, path: &Path) -> Result<AtomicFile> {
        if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
            let mut missing = Vec::new();
            let mut p = Some(parent);
            while let Some(q) = p.filter(|q| !q.as_os_str().is_empty() && !q.exists()) {
                missing.push(q.to_path_buf());
                p = q.parent();
            }
            for dir in missing.into_iter().rev() {
                std::fs::create_dir(&dir).map_err(|e| Error::io(&dir, e))?;
                self.made_dirs.push(dir);
            }
        }
        AtomicFile::create(path)
    }

    /// Adds a file being written to the set.
    pub fn add(&mut self, file: AtomicFile) {
        self.files.push(file);
    }

    /// Writes `bytes` as the output `path`, to be renamed into place by
    /// [`OutputSet::commit`].
    pub fn write(&mut self, path: &Path, bytes: &[u8]) -> Result<()> {
        let mut f = self.create(path)?;
        f.write_all(bytes).map_err(|e| Error::io(path, e))?;
        self.add(f);
        Ok(())
    }

    /// Syncs every file, then renames each into place. Should a rename fail
    /// (the sync succeeded, so only a path that changed meanwhile does), the
    /// outputs already renamed that did not exist before are removed again
    /// (one that replaced an earlier file keeps the new content).
    pub fn commit(mut self) -> Result<()> {
        for f in &mut self.files {
            f.sync()?;
        }
        let mut new_files = Vec::new();
        let files = std::mem::take(&mut self.files);
        for mut f in files {
            let existed = f.path.symlink_metadata().is_ok();
            if let Err(e) = f.rename() {
                for p in &new_files {
                    let _ = std::fs::remove_file(p);
                }
                return Err(e); // dropping the set removes the rest
            }
            if !existed {
                new_files.push(f.path.clone());
            }
        }
        self.made_dirs.clear();
        Ok(())
    }
}

impl Drop for OutputSet {
    fn drop(&mut self) {
        self.files.clear(); // each removes its temporary file
        for dir in self.made_dirs.iter().rev() {
            let _ = std::fs::remove_dir(dir); // only if empty
        }
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.file.as_mut().expect("not committed").write(buf)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.file.as_mut().expect("not committed").flush()
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if self.file.take().is_some() || self.tmp.exists() {
            let _ = std::fs::remove_file(&self.tmp);
        }
        forget(&self.tmp);
    }
}

/// Takes `tmp` off the list of temporary files.
fn forget(tmp: &Path) {
    let mut p = pending();
    if let Some(i) = p.0.iter().position(|q| q == tmp) {
        p.0.swap_remove(i);
    }
}

/// Writes `bytes` to `path` atomically: to a temporary file beside it, synced,
/// then renamed into place. On failure the temporary file is removed and
/// `path` is left as it was.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let mut f = AtomicFile::create(path)?;
    f.write_all(bytes).map_err(|e| Error::io(path, e))?;
    f.commit()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atomic_write_replaces_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("out.txt");
        write_atomic(&p, b"one").unwrap();
        write_atomic(&p, b"two").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"two");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn limited_read_refuses_long_files_and_endless_streams() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("f");
        std::fs::write(&p, b"0123456789").unwrap();
        assert_eq!(read_limited(&p, 10, "map").unwrap(), b"0123456789");
        let e = read_limited(&p, 9, "map").unwrap_err().to_string();
        assert!(e.contains("larger than the limit of 9 bytes"), "{e}");
        // An endless stream: stops after limit + 1 bytes.
        let b = read_to_limit(std::io::repeat(0), 1000, &p).unwrap();
        assert_eq!(b.len(), 1001);
        assert_eq!(human_bytes(1 << 30), "1 GiB");
        assert_eq!(human_bytes(16 << 20), "16 MiB");
    }

    #[test]
    fn an_uncommitted_atomic_file_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("out.csv");
        std::fs::write(&p, "old").unwrap();
        let mut f = AtomicFile::create(&p).unwrap();
        f.write_all(b"half").unwrap();
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
        drop(f);
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "old");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
        // (remove_temporaries is tested through the binary, on SIGTERM: here
        // it would remove other tests' files being written.)
    }

    #[test]
    fn outputs_named_with_250_bytes_are_written_atomically() {
        let dir = tempfile::tempdir().unwrap();
        // 250 bytes: the temporary name `.NAME.tmpPID` was 260 and more,
        // past the file systems' 255, and the write failed.
        let name = "a".repeat(249) + "1";
        assert_eq!(name.len(), 250);
        let p = dir.path().join(&name);
        write_atomic(&p, b"one").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"one");
        // Two such files at once, their names the same but for the last
        // byte (the temporary names cut there): each keeps its own bytes.
        let q = dir.path().join("a".repeat(249) + "2");
        let (mut f, mut g) = (
            AtomicFile::create(&p).unwrap(),
            AtomicFile::create(&q).unwrap(),
        );
        assert_ne!(f.tmp, g.tmp);
        f.write_all(b"two").unwrap();
        g.write_all(b"three").unwrap();
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 3);
        f.commit().unwrap();
        g.commit().unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"two");
        assert_eq!(std::fs::read(&q).unwrap(), b"three");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
        // Dropped uncommitted: the old file is kept, no temporary left.
        let mut f = AtomicFile::create(&p).unwrap();
        f.write_all(b"half").unwrap();
        drop(f);
        assert_eq!(std::fs::read(&p).unwrap(), b"two");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
        // A name of multi-byte characters is cut at a character boundary.
        let t = temporary_name(&"é".repeat(125));
        assert!(t.len() <= MAX_NAME_BYTES && t.starts_with(".é"), "{t}");
        assert!(temporary_name("out.csv").starts_with(".out.csv.tmp"));
        // A name too long for the file itself: refused before any temporary.
        let e = AtomicFile::create(&dir.path().join("a".repeat(256))).unwrap_err();
        assert!(
            e.to_string()
                .contains("256 bytes long, above the limit of 255"),
            "{e}"
        );
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
    }

    #[test]
    fn atomic_write_into_missing_folder_fails_cleanly() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("missing").join("out.txt");
        assert!(write_atomic(&p, b"x").is_err());
        assert!(!p.exists());
    }
}
