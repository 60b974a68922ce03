//! Integration tests: see tests/.
