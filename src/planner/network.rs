//! Network coverage (in progress).
