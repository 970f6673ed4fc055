//! Simulated Uno (work in progress).
