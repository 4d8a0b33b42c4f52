//! The scalar a chain samples: colour contributions are reduced to one number and the recorder
//! re-weights each colour by it (charted-MLT paper §3.4). One choice is used everywhere — bootstrap,
//! chains and recording — since mixing them renders too dark.

use crate::spectrum::Rgb;

/// How a colour becomes the scalar importance.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ImportanceKind {
    /// Rec. 709 luminance (Kelemen, pbrt).
    #[default]
    Luminance,
    /// The largest component (charted MLT), which never gives zero importance to a coloured path.
    MaxComponent,
}

impl ImportanceKind {
    /// The scalar of a colour (non-negative).
    #[inline]
    pub fn of(&self, c: Rgb) -> f64 {
        match self {
            ImportanceKind::Luminance => c.luminance().max(0.0),
            ImportanceKind::MaxComponent => c.max_component().max(0.0),
        }
    }
}
