//! The one error type of isokit-io.

use std::path::{Path, PathBuf};

use isokit_field::FieldError;

/// Everything that can go wrong reading or writing a file. Every variant that concerns a file
/// names it. `to_string()` is a complete one-line message for a user, except for
/// [`IoError::Io`], whose operating-system reason is its [`std::error::Error::source`]
/// (printed once by anyhow's `{:#}` as `path: reason`; not repeated in the message itself).
#[derive(Debug, thiserror::Error)]
pub enum IoError {
    /// The operating system refused a read, write, rename, …. The message names the file;
    /// the operating system's words are the [`std::error::Error::source`] (print the chain,
    /// e.g. anyhow's `{:#}`, to see both; they are not repeated in this message).
    #[error("{}", crate::util::shown_path(path))]
    Io {
        /// The file concerned.
        path: PathBuf,
        /// What the operating system said.
        #[source]
        source: std::io::Error,
    },
    /// The file's content does not follow its format (truncated, inconsistent header,
    /// out-of-range index, unparsable number, …).
    #[error("{}: {}", crate::util::shown_path(path), crate::util::shown_text(msg))]
    Malformed {
        /// The file concerned.
        path: PathBuf,
        /// What is wrong, and where when known.
        msg: String,
    },
    /// The file is valid but uses a feature this crate does not read (e.g. a sparse glTF
    /// accessor, a rotated NRRD grid, a 4-D NIfTI series).
    #[error(
        "{}: unsupported: {}",
        crate::util::shown_path(path),
        crate::util::shown_text(what)
    )]
    Unsupported {
        /// The file concerned.
        path: PathBuf,
        /// The feature.
        what: String,
    },
    /// The file name's extension names no format this operation handles.
    #[error(
        "{}: unrecognized file extension; expected {expected}",
        crate::util::shown_path(path)
    )]
    UnknownFormat {
        /// The file concerned.
        path: PathBuf,
        /// The extensions accepted, for the message.
        expected: &'static str,
    },
    /// The data handed to a writer cannot be written (wrong lengths, out-of-range indices,
    /// non-finite spacing, …). Nothing was written.
    #[error(
        "{}: cannot write: {}",
        crate::util::shown_path(path),
        crate::util::shown_text(msg)
    )]
    InvalidInput {
        /// The file that was to be written.
        path: PathBuf,
        /// What is wrong with the data.
        msg: String,
    },
    /// A volume's spacing differs between axes where a uniform [`isokit_field::Grid`] is
    /// needed.
    #[error(
        "volume spacing ({}, {}, {}) is anisotropic (relative tolerance 1e-4); resample it to a uniform spacing first (Volume::resample_uniform)",
        spacing[0], spacing[1], spacing[2]
    )]
    Anisotropic {
        /// The spacings along x, y, z.
        spacing: [f32; 3],
    },
    /// A volume's fields are inconsistent (data length, spacing, origin).
    #[error("invalid volume: {}", crate::util::shown_text(.0))]
    InvalidVolume(String),
    /// A grid could not be built (bad sizes, spacing, origin).
    #[error(transparent)]
    Field(#[from] FieldError),
}

impl IoError {
    /// [`IoError::Io`] for `path`.
    pub fn io(path: &Path, source: std::io::Error) -> Self {
        IoError::Io {
            path: path.to_path_buf(),
            source,
        }
    }
    /// [`IoError::Malformed`] for `path`: `msg` says what is wrong, and where when known
    /// (`"line 57: …"`).
    pub fn malformed(path: &Path, msg: impl Into<String>) -> Self {
        IoError::Malformed {
            path: path.to_path_buf(),
            msg: msg.into(),
        }
    }
    pub(crate) fn unsupported(path: &Path, what: impl Into<String>) -> Self {
        IoError::Unsupported {
            path: path.to_path_buf(),
            what: what.into(),
        }
    }
    pub(crate) fn invalid_input(path: &Path, msg: impl Into<String>) -> Self {
        IoError::InvalidInput {
            path: path.to_path_buf(),
            msg: msg.into(),
        }
    }

    /// The file this error concerns, when it concerns one.
    pub fn path(&self) -> Option<&Path> {
        match self {
            IoError::Io { path, .. }
            | IoError::Malformed { path, .. }
            | IoError::Unsupported { path, .. }
            | IoError::UnknownFormat { path, .. }
            | IoError::InvalidInput { path, .. } => Some(path),
            _ => None,
        }
    }
}
