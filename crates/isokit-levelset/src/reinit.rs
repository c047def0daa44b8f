//! Module reinit.
