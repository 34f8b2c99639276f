//! Puddle World (filled in by the env work).
