//! The sans-IO client (being written).
