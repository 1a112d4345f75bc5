//! Master against the simulated Bürkert device on the in-memory bus (virtual clock).
