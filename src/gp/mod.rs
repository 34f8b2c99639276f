//! Gaussian-process regression (filled in by the gp work).
