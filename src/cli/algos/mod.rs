//! One file per algorithm: its registry entry and how it is built from the options.

pub mod bdpt;
pub mod cmlt;
pub mod erpt;
pub mod lt;
pub mod memlt;
pub mod mept;
pub mod mlt;
pub mod mmlt;
pub mod mps;
pub mod pm;
pub mod pssmlt;
pub mod pt;
