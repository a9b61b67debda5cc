//! Error types shared across the crate.

use std::fmt;
use std::path::{Path, PathBuf};

/// A bad input: names the file, the key or line, and the reason.
/// The CLI maps it to exit code 2.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct InputError {
    /// The offending file (or `<command line>`).
    pub file: PathBuf,
    /// Key path (`network.edges[2]`) or `line N`, when known.
    pub location: Option<String>,
    /// What is wrong.
    pub reason: String,
}

impl InputError {
    /// An error at `location` in `file`.
    pub fn at(file: &Path, location: impl Into<String>, reason: impl Into<String>) -> Self {
        InputError {
            file: file.to_path_buf(),
            location: Some(location.into()),
            reason: reason.into(),
        }
    }

    /// An error about `file` as a whole.
    pub fn file(file: &Path, reason: impl Into<String>) -> Self {
        InputError {
            file: file.to_path_buf(),
            location: None,
            reason: reason.into(),
        }
    }
}

/// The text of the file `path`, `what` it is for the reason, refused
/// before more than `limit` bytes are read (a larger file is no file
/// sonarnet reads: its error says so and names the limit).
pub fn read_text_at_most(path: &Path, limit: u64, what: &str) -> Result<String, InputError> {
    use std::io::Read;
    let file = std::fs::File::open(path)
        .map_err(|e| InputError::file(path, format!("cannot read {what}: {e}")))?;
    let mut text = String::new();
    file.take(limit.saturating_add(1))
        .read_to_string(&mut text)
        .map_err(|e| InputError::file(path, format!("cannot read {what}: {e}")))?;
    if text.len() as u64 > limit {
        return Err(InputError::file(
            path,
            format!("longer than {limit} bytes, the most a {what} file may hold"),
        ));
    }
    Ok(text)
}

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file.display())?;
        if let Some(loc) = &self.location {
            write!(f, ": {loc}")?;
        }
        write!(f, ": {}", self.reason)
    }
}

impl std::error::Error for InputError {}

/// A bad value of one key: the key's path (`channel.loss.p`,
/// `faults[0].node`) and the reason. Checks below the file level return it;
/// [`KeyError::in_file`] makes it an [`InputError`] naming the file.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{key}: {reason}")]
pub struct KeyError {
    /// The key's path.
    pub key: String,
    /// What is wrong with its value.
    pub reason: String,
}

impl KeyError {
    /// The key `key` is wrong because of `reason`.
    pub fn new(key: impl Into<String>, reason: impl Into<String>) -> Self {
        KeyError {
            key: key.into(),
            reason: reason.into(),
        }
    }

    /// The same error with the key under `prefix` (`faults[2]` + `node`:
    /// `faults[2].node`).
    pub fn under(self, prefix: &str) -> Self {
        KeyError {
            key: format!("{prefix}.{}", self.key),
            reason: self.reason,
        }
    }

    /// The error in `file`.
    pub fn in_file(self, file: &Path) -> InputError {
        InputError::at(file, self.key, self.reason)
    }
}

/// A [`KeyError`] unless `lo <= v <= hi` (and finite): the range check
/// of the channel's and the faults' keys.
pub(crate) fn in_range(key: &str, v: f64, lo: f64, hi: f64) -> Result<(), KeyError> {
    if v.is_finite() && v >= lo && v <= hi {
        Ok(())
    } else {
        Err(KeyError::new(key, format!("{v} is outside [{lo}, {hi}]")))
    }
}
