//! Writing files without losing data. Every output is written to a temporary file in
//! its own folder and renamed onto its name only once it is complete, so an
//! interrupted or failed run leaves either the old file or the new one, never a
//! half-written one. A path that is a link is written through: the file it points at
//! is replaced and the link stays. A path that exists but is no plain file (a device
//! such as `/dev/null`, a pipe) is written in place, since renaming onto it would
//! replace the device.

use std::fs::{self, File, OpenOptions};
use std::io::{ErrorKind, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use super::IoError;

/// The folder a path's file lies in (`.` for a bare file name).
pub fn folder_of(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Where writing `path` lands, as an absolute path without links: the canonical path
/// of the file when it exists (following links), else its folder's canonical path
/// joined with its name. Fails when the folder does not exist, is no folder, or the
/// path names no file (`..`, a trailing `/`), or is a link to nothing.
pub fn resolve(path: &Path) -> Result<PathBuf, IoError> {
    match fs::symlink_metadata(path) {
        Ok(meta) => fs::canonicalize(path).map_err(|e| {
            if meta.file_type().is_symlink() && e.kind() == ErrorKind::NotFound {
                IoError::format(
                    "is a link to a file or folder that does not exist: give the real path",
                )
                .in_file(path)
            } else {
                IoError::os(path, "resolve", e)
            }
        }),
        Err(e) if e.kind() == ErrorKind::NotFound => {
            let Some(name) = path.file_name() else {
                return Err(IoError::format("names no file: give a file name").in_file(path));
            };
            let folder = folder_of(path);
            let canonical = fs::canonicalize(folder).map_err(|e| {
                if e.kind() == ErrorKind::NotFound {
                    IoError::format(format!(
                        "the folder {} does not exist: create it first or write elsewhere",
                        folder.display()
                    ))
                    .in_file(path)
                } else {
                    IoError::os(folder, "resolve", e)
                }
            })?;
            if !canonical.is_dir() {
                return Err(IoError::format(format!(
                    "{} is not a folder, so nothing can be written in it",
                    folder.display()
                ))
                .in_file(path));
            }
            Ok(canonical.join(name))
        }
        Err(e) => Err(IoError::os(path, "inspect", e)),
    }
}

static TEMP_SERIAL: AtomicU64 = AtomicU64::new(0);

/// Suffix of the temporary files outputs are written to before their rename.
pub const TEMP_SUFFIX: &str = ".lfdepth-partial";

/// Creates a new, empty temporary file in `folder` for the output `name`:
/// `.NAME.PID-N.lfdepth-partial` (hidden, and named after what it will become).
fn create_temp(folder: &Path, name: &str) -> std::io::Result<(PathBuf, File)> {
    // Leave room in a 255-byte file name for the prefix and suffix.
    let mut short = name.to_string();
    while short.len() > 180 {
        short.pop();
    }
    loop {
        let serial = TEMP_SERIAL.fetch_add(1, Ordering::Relaxed);
        let temp = folder.join(format!(
            ".{short}.{}-{serial}{TEMP_SUFFIX}",
            std::process::id()
        ));
        match OpenOptions::new().write(true).create_new(true).open(&temp) {
            Ok(file) => return Ok((temp, file)),
            Err(e) if e.kind() == ErrorKind::AlreadyExists => continue,
            Err(e) => return Err(e),
        }
    }
}

/// Checks that files can be created in `folder` (by creating and removing a temporary
/// one); `path` is the output the check is for, named in the error.
pub fn check_folder_writable(folder: &Path, path: &Path) -> Result<(), IoError> {
    match create_temp(folder, "write-check") {
        Ok((temp, file)) => {
            drop(file);
            let _ = fs::remove_file(temp);
            Ok(())
        }
        Err(e) => Err(IoError::format(format!(
            "cannot write in the folder {}: {e}",
            folder.display()
        ))
        .in_file(path)),
    }
}

/// Checks, without changing anything, that `path` can be written: its folder exists
/// and takes new files, and the path is no folder and, when it exists, is writable.
pub fn check_writable(path: &Path) -> Result<(), IoError> {
    let target = resolve(path)?;
    match fs::metadata(&target) {
        Ok(meta) if meta.is_dir() => {
            return Err(IoError::format("is a folder: give a file name").in_file(path))
        }
        Ok(meta) if !meta.is_file() => {
            // A device or pipe: opening it for writing could block or have effects.
            return Ok(());
        }
        Ok(_) => {
            OpenOptions::new()
                .write(true)
                .open(&target)
                .map_err(|e| IoError::os(path, "write", e))?;
        }
        Err(e) if e.kind() == ErrorKind::NotFound => {}
        Err(e) => return Err(IoError::os(path, "inspect", e)),
    }
    check_folder_writable(folder_of(&target), path)
}

/// Writes a whole file by way of a temporary file renamed onto `path` (see the module
/// docs); errors name `path`. The new file keeps an old file's permissions.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), IoError> {
    let target = resolve(path)?;
    let permissions = match fs::metadata(&target) {
        Ok(meta) if meta.is_dir() => {
            return Err(IoError::format("is a folder: give a file name").in_file(path))
        }
        Ok(meta) if !meta.is_file() => {
            return fs::write(&target, bytes).map_err(|e| IoError::os(path, "write", e));
        }
        Ok(meta) => {
            // Refuse what a plain write would refuse (a read-only file), although the
            // rename itself would succeed.
            OpenOptions::new()
                .write(true)
                .open(&target)
                .map_err(|e| IoError::os(path, "write", e))?;
            Some(meta.permissions())
        }
        Err(e) if e.kind() == ErrorKind::NotFound => None,
        Err(e) => return Err(IoError::os(path, "inspect", e)),
    };
    let name = target
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let (temp, mut file) =
        create_temp(folder_of(&target), &name).map_err(|e| IoError::os(path, "write", e))?;
    let written = file
        .write_all(bytes)
        .and_then(|()| match permissions {
            Some(p) => file.set_permissions(p),
            None => Ok(()),
        })
        .and_then(|()| file.sync_all());
    drop(file);
    let renamed = written.and_then(|()| fs::rename(&temp, &target));
    if let Err(e) = renamed {
        let _ = fs::remove_file(&temp);
        return Err(IoError::os(path, "write", e));
    }
    Ok(())
}

/// Whether two existing paths are the same file (also through hard links).
pub fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let (Ok(x), Ok(y)) = (fs::metadata(a), fs::metadata(b)) {
            return x.dev() == y.dev() && x.ino() == y.ino();
        }
    }
    match (fs::canonicalize(a), fs::canonicalize(b)) {
        (Ok(x), Ok(y)) => x == y,
        _ => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp_names(dir: &Path) -> Vec<String> {
        fs::read_dir(dir)
            .unwrap()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n.ends_with(TEMP_SUFFIX))
            .collect()
    }

    #[test]
    fn replaces_a_file_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.bin");
        fs::write(&path, b"old").unwrap();
        // A reader of the old file keeps reading it whole: the name is moved onto a new
        // file, the old one is never truncated or rewritten.
        let old = File::open(&path).unwrap();
        write_atomic(&path, b"new contents").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"new contents");
        assert_eq!(std::io::read_to_string(old).unwrap(), "old");
        assert!(temp_names(dir.path()).is_empty());
    }

    #[test]
    fn a_failed_write_keeps_the_old_file() {
        let dir = tempfile::tempdir().unwrap();
        // The target is a non-empty folder: the rename fails after the data is written.
        let path = dir.path().join("taken");
        fs::create_dir(&path).unwrap();
        fs::write(path.join("inside"), b"keep").unwrap();
        assert!(write_atomic(&path, b"x").is_err());
        assert_eq!(fs::read(path.join("inside")).unwrap(), b"keep");
        assert!(temp_names(dir.path()).is_empty());
    }

    #[test]
    fn missing_folders_are_named() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("no-such-folder").join("out.pfm");
        let e = write_atomic(&path, b"x").unwrap_err().to_string();
        assert!(e.contains("does not exist"), "{e}");
        assert!(check_writable(&path).is_err());
        assert!(check_writable(&dir.path().join("fine.pfm")).is_ok());
        assert!(check_writable(dir.path()).is_err());
    }

    #[cfg(unix)]
    #[test]
    fn links_are_written_through() {
        let dir = tempfile::tempdir().unwrap();
        let real = dir.path().join("real.pfm");
        let link = dir.path().join("link.pfm");
        fs::write(&real, b"old").unwrap();
        std::os::unix::fs::symlink(&real, &link).unwrap();
        write_atomic(&link, b"new").unwrap();
        assert!(fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink());
        assert_eq!(fs::read(&real).unwrap(), b"new");
        assert!(same_file(&real, &link));
    }
}
