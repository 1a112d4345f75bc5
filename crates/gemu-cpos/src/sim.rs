//! The simulated cPos (being written).
