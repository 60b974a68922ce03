//! iceoryx2 services of one run (placeholder, filled in next).
