//! Module evolve.
