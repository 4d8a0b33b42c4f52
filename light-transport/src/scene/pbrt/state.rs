//! The graphics state of the pbrt format and its stack: `AttributeBegin` saves the whole state
//! (transform, material, area light, `ReverseOrientation`, and the named materials and textures
//! defined inside the block, which pbrt scopes to it); `TransformBegin` saves only the transform.

use crate::error::Location;
use crate::math::DMat4;
use crate::scene::description::{AreaLightDesc, RgbTexture};
use std::collections::HashMap;
use std::rc::Rc;

/// What applies to the next shapes.
#[derive(Clone, Debug)]
pub(crate) struct GraphicsState {
    /// Current transformation matrix (object to world inside the world block).
    pub ctm: DMat4,
    /// `ReverseOrientation` parity.
    pub reverse_orientation: bool,
    /// Current material; `None` means pbrt's default (matte, `Kd` 0.5).
    pub material: Option<usize>,
    /// Current area light.
    pub area_light: Option<AreaLightDesc>,
    /// Named materials in scope.
    pub named_materials: Rc<HashMap<String, usize>>,
    /// Spectrum textures in scope.
    pub rgb_textures: Rc<HashMap<String, RgbTexture>>,
    /// Float textures in scope (constants only).
    pub float_textures: Rc<HashMap<String, f64>>,
}

impl Default for GraphicsState {
    fn default() -> Self {
        Self {
            ctm: DMat4::IDENTITY,
            reverse_orientation: false,
            material: None,
            area_light: None,
            named_materials: Rc::default(),
            rgb_textures: Rc::default(),
            float_textures: Rc::default(),
        }
    }
}

/// The two kinds of blocks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum BlockKind {
    /// `AttributeBegin` … `AttributeEnd`.
    Attribute,
    /// `TransformBegin` … `TransformEnd`.
    Transform,
}

impl BlockKind {
    /// The directive that opens the block.
    pub fn begin(self) -> &'static str {
        match self {
            Self::Attribute => "AttributeBegin",
            Self::Transform => "TransformBegin",
        }
    }

    /// The directive that closes the block.
    pub fn end(self) -> &'static str {
        match self {
            Self::Attribute => "AttributeEnd",
            Self::Transform => "TransformEnd",
        }
    }
}

/// An open block and what to restore when it closes.
#[derive(Debug)]
pub(crate) struct Block {
    /// Kind.
    pub kind: BlockKind,
    /// Where it was opened.
    pub opened: Location,
    /// The saved state (only `ctm` is restored by `TransformEnd`).
    pub saved: GraphicsState,
}
