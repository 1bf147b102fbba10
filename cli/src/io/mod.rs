//! File formats and scene loading. Every reader reports what is wrong with which file;
//! none panics or allocates more than the file can justify.

pub mod cfg;
pub mod formats;
pub mod limits;
pub mod needs;
pub mod output;
pub mod pattern;
pub mod pfm;
pub mod png;
pub mod scene;

use std::fmt;
use std::path::{Path, PathBuf};

/// A failure to read, decode or write a file, with the file it concerns (when known).
#[derive(Debug)]
pub struct IoError {
    /// The file or folder concerned; `None` for in-memory decoding.
    pub path: Option<PathBuf>,
    /// What went wrong.
    pub detail: Detail,
}

/// What went wrong in an [`IoError`].
#[derive(Debug)]
#[non_exhaustive]
pub enum Detail {
    /// The operating system refused (`action` is e.g. "read" or "write").
    Os {
        action: &'static str,
        source: std::io::Error,
    },
    /// The content is malformed or unsupported; the message says what to change.
    Format(String),
    /// The core rejected the data (e.g. an unsupported view grid).
    Core(lfdepth::Error),
}

impl IoError {
    /// A malformed-content error not yet tied to a file.
    pub fn format(message: impl Into<String>) -> Self {
        IoError {
            path: None,
            detail: Detail::Format(message.into()),
        }
    }

    /// An operating-system error while doing `action` on `path`.
    pub fn os(path: &Path, action: &'static str, source: std::io::Error) -> Self {
        IoError {
            path: Some(path.to_path_buf()),
            detail: Detail::Os { action, source },
        }
    }

    /// A core error about the data in `path`.
    pub fn core(path: &Path, source: lfdepth::Error) -> Self {
        IoError {
            path: Some(path.to_path_buf()),
            detail: Detail::Core(source),
        }
    }

    /// Ties the error to `path` unless it already names a file.
    pub fn in_file(mut self, path: &Path) -> Self {
        if self.path.is_none() {
            self.path = Some(path.to_path_buf());
        }
        self
    }
}

impl fmt::Display for IoError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(path) = &self.path {
            write!(f, "{}: ", path.display())?;
        }
        match &self.detail {
            Detail::Os { action, source } => write!(f, "cannot {action} it: {source}"),
            Detail::Format(message) => f.write_str(message),
            Detail::Core(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for IoError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match &self.detail {
            Detail::Os { source, .. } => Some(source),
            Detail::Core(e) => Some(e),
            Detail::Format(_) => None,
        }
    }
}

/// Opens `path` for reading if it is a plain file, with its length; anything else (a
/// folder, a FIFO, a device) is refused by what it is, `hint` saying what it must be.
/// The kind is read before opening: opening a FIFO would wait for a writer.
pub(crate) fn open_regular(
    path: &std::path::Path,
    hint: &str,
) -> Result<(std::fs::File, u64), IoError> {
    let kind = std::fs::metadata(path).map_err(|e| IoError::os(path, "read", e))?;
    if !kind.is_file() {
        return Err(IoError::format(format!(
            "is {}, not a file: {hint}",
            kind_of(&kind.file_type())
        ))
        .in_file(path));
    }
    let file = std::fs::File::open(path).map_err(|e| IoError::os(path, "read", e))?;
    let meta = file.metadata().map_err(|e| IoError::os(path, "read", e))?;
    if !meta.is_file() {
        return Err(IoError::format(format!("is not a file: {hint}")).in_file(path));
    }
    Ok((file, meta.len()))
}

/// What a file-system entry that is not a plain file is, for messages ("a folder").
pub(crate) fn kind_of(kind: &std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if kind.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if kind.is_socket() {
            return "a socket";
        }
        if kind.is_block_device() || kind.is_char_device() {
            return "a device";
        }
    }
    if kind.is_dir() {
        "a folder"
    } else if kind.is_symlink() {
        "a symbolic link"
    } else if kind.is_file() {
        "a file"
    } else {
        "something other than a file"
    }
}

/// Reads a whole file, naming it in the error.
pub(crate) fn read_bytes(path: &Path) -> Result<Vec<u8>, IoError> {
    std::fs::read(path).map_err(|e| IoError::os(path, "read", e))
}

/// Writes a whole file by way of a temporary file renamed into place
/// ([`output::write_atomic`]), naming it in the error.
pub(crate) fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), IoError> {
    output::write_atomic(path, bytes)
}
