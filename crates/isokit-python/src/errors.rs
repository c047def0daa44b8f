//! Library errors as Python exceptions, with the command's messages.
//!
//! | library error | Python exception |
//! | --- | --- |
//! | a file that does not exist | `FileNotFoundError` |
//! | a file that cannot be read or written (permissions, a folder, …) | `OSError` (or its subclass) |
//! | a malformed or unsupported file, a bad parameter, a bad scene | `ValueError` |
//! | a wrong type or dtype | `TypeError` |
//! | a computation cancelled through its progress callback | `isokit.Cancelled` |
//! | Ctrl-C | `KeyboardInterrupt` |
//! | a bug (a caught panic) | `RuntimeError` |

use isokit_io::IoError;
use isokit_scene::SceneError;
use pyo3::exceptions::{
    PyFileNotFoundError, PyIsADirectoryError, PyOSError, PyPermissionError, PyValueError,
};
use pyo3::prelude::*;

pyo3::create_exception!(
    isokit,
    Cancelled,
    pyo3::exceptions::PyException,
    "A long call was cancelled: its progress callback returned False."
);

/// An `OSError` subclass for an operating-system error kind.
fn os_error(kind: std::io::ErrorKind, msg: String) -> PyErr {
    use std::io::ErrorKind as K;
    match kind {
        K::NotFound => PyFileNotFoundError::new_err(msg),
        K::PermissionDenied => PyPermissionError::new_err(msg),
        K::IsADirectory => PyIsADirectoryError::new_err(msg),
        _ => PyOSError::new_err(msg),
    }
}

/// An error and its causes, joined by `: ` (an I/O error's reason is its source).
pub fn chain(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        s.push_str(": ");
        s.push_str(&c.to_string());
        cause = c.source();
    }
    s
}

/// A file-format error.
pub fn io_err(e: IoError) -> PyErr {
    let msg = chain(&e);
    match &e {
        IoError::Io { source, .. } => os_error(source.kind(), msg),
        _ => PyValueError::new_err(msg),
    }
}

/// A scene error: `file: node: message`, as the command prints it.
pub fn scene_err(e: SceneError) -> PyErr {
    let msg = e.to_string();
    let m = e.message.as_str();
    if m.starts_with("no such file") || m.contains("No such file") {
        PyFileNotFoundError::new_err(msg)
    } else if m.contains("is a directory, not a file") {
        PyIsADirectoryError::new_err(msg)
    } else if m.starts_with("cannot read") || m.contains("Permission denied") {
        PyOSError::new_err(msg)
    } else {
        PyValueError::new_err(msg)
    }
}

/// Any other library error as a `ValueError`.
pub fn value_err(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}
