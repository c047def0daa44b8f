//! Module morph.
