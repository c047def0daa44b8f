//! isokit
