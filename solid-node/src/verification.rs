//! Verification cases (filled in below).
