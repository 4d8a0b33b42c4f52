//! The lobes of each material that is the same at every surface point, built once per scene.
//!
//! A BSDF is built per hit (Veach 1997 §10.3's vertices each carry one) by walking the material's
//! tree: parameter checks, texture lookups, the flattening of mixes. For a material without an
//! image texture that walk gives the same lobes at every point, so the scene builds them once and a
//! hit copies them into its vertex's BSDF ([`super::Bsdf::rebuild_from`]); only the shading frame
//! is the hit's own. Materials whose lobes vary over the surface, or whose tree is rejected, are
//! still built point by point ([`super::Bsdf::rebuild`]), with the same result and the same errors.

use super::lobes::Lobes;
use super::material;
use crate::scene::{MaterialDesc, TextureDesc};
use std::sync::atomic::{AtomicU64, Ordering};

/// Per material, its lobes when they are the same at every surface point.
#[derive(Clone, Debug, Default)]
pub struct PrebuiltLobes {
    per_material: Vec<Option<Lobes>>,
}

impl PrebuiltLobes {
    /// The lobes of every material of `materials` that has no image texture in its tree and is
    /// valid.
    pub fn new(materials: &[MaterialDesc], textures: &[TextureDesc]) -> Self {
        // Each table's entries carry their own marks, so that lobes copied from one scene's table
        // are never taken for another's.
        static NEXT_TABLE: AtomicU64 = AtomicU64::new(0);
        let table = NEXT_TABLE.fetch_add(1, Ordering::Relaxed);
        let per_material = (0..materials.len())
            .map(|m| {
                if material::varies_over_surface(materials, m) {
                    return None;
                }
                let mut lobes = Lobes::default();
                material::build(&mut lobes, materials, textures, m, [0.0, 0.0]).ok()?;
                // Table and material each fit in 32 bits (materials are numbered in u32 by the
                // scene's primitives; four billion scenes in one process are not built), so
                // marks never collide, nor equal `NO_ORIGIN`'s all-ones.
                debug_assert!(table < u64::from(u32::MAX) && m < u32::MAX as usize);
                lobes.set_origin((table << 32) | m as u64);
                Some(lobes)
            })
            .collect();
        Self { per_material }
    }

    /// The lobes of material `material`, if they were built once.
    #[inline]
    pub fn get(&self, material: usize) -> Option<&Lobes> {
        self.per_material.get(material)?.as_ref()
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::scene::RgbTexture;
    use crate::spectrum::Rgb;

    fn matte(kd: RgbTexture) -> MaterialDesc {
        MaterialDesc::Matte { kd }
    }

    fn layered(alpha: f64) -> MaterialDesc {
        MaterialDesc::Layered {
            kd: RgbTexture::Constant(Rgb::new(0.5, 0.4, 0.3)),
            ks: Rgb::splat(0.2),
            alpha_u: alpha,
            alpha_v: alpha,
            eta: 1.5,
        }
    }

    fn mix(a: usize, b: usize) -> MaterialDesc {
        MaterialDesc::Mix {
            a,
            b,
            amount: Rgb::new(0.3, 0.5, 0.7),
        }
    }

    /// A 2×2 checker of four grey levels, repeated `repeats` times across `[0, 1)²` (also used by
    /// the scene's test of BSDFs at hits).
    pub(crate) fn checker(repeats: f64) -> TextureDesc {
        TextureDesc {
            texels: vec![
                Rgb::splat(0.9),
                Rgb::splat(0.1),
                Rgb::splat(0.2),
                Rgb::splat(0.8),
            ],
            width: 2,
            height: 2,
            uv_scale: [repeats, repeats],
            uv_offset: [0.0, 0.0],
            name: "checker".into(),
        }
    }

    /// Materials of every kind, textured and not, nested, spilling past the inline lobes, and
    /// invalid.
    fn materials() -> Vec<MaterialDesc> {
        vec![
            /* 0 */
            matte(RgbTexture::Image {
                texture: 0,
                scale: Rgb::WHITE,
            }),
            /* 1 */ matte(RgbTexture::Constant(Rgb::splat(0.5))),
            /* 2 */ mix(0, 1),
            /* 3 */
            MaterialDesc::Metal {
                eta: Rgb::new(0.2, 0.9, 1.1),
                k: Rgb::new(3.9, 2.4, 2.2),
                alpha_u: 0.1,
                alpha_v: 0.3,
            },
            /* 4 */
            MaterialDesc::Glass {
                eta: 1.5,
                alpha_u: 0.0,
                alpha_v: 0.0,
                kr: Rgb::WHITE,
                kt: Rgb::WHITE,
            },
            /* 5 */ layered(0.2),
            /* 6 */ mix(5, 3),
            /* 7 */ mix(6, 5), // five lobes: spilled
            /* 8 */ matte(RgbTexture::Constant(Rgb::splat(-1.0))), // invalid
            /* 9 */ mix(8, 1),
            /* 10 */ mix(7, 2), // textured deep down
            /* 11 */ MaterialDesc::Mirror {
                kr: Rgb::splat(0.9),
            },
        ]
    }

    #[test]
    fn prebuilt_lobes_are_the_lobes_built_at_every_point() {
        let (m, t) = (materials(), vec![checker(1.0)]);
        let pre = PrebuiltLobes::new(&m, &t);
        for (i, expect_prebuilt) in [
            false, true, false, true, true, true, true, true, false, false, false, true,
        ]
        .into_iter()
        .enumerate()
        {
            assert_eq!(pre.get(i).is_some(), expect_prebuilt, "material {i}");
            let Some(lobes) = pre.get(i) else { continue };
            for uv in [[0.0, 0.0], [0.3, 0.8], [0.75, 0.25]] {
                let mut at_point = Lobes::default();
                material::build(&mut at_point, &m, &t, i, uv).unwrap();
                assert_eq!(*lobes, at_point, "material {i} at {uv:?}");
            }
        }
        assert_eq!(pre.get(7).map(|l| l.as_slice().len()), Some(5));
        // The textured ones differ from point to point: prebuilding them would be wrong.
        let at = |uv| {
            let mut l = Lobes::default();
            material::build(&mut l, &m, &t, 2, uv).unwrap();
            l
        };
        assert_ne!(at([0.25, 0.75]), at([0.75, 0.75]));
        assert!(pre.get(12).is_none(), "out of range");
    }

    /// A copy into a list holds the source's lobes and groups, and keeps spilled storage.
    #[test]
    fn a_copy_of_lobes_is_the_list_in_the_storage_it_has() {
        let (m, t) = (materials(), vec![checker(1.0)]);
        let pre = PrebuiltLobes::new(&m, &t);
        let (one, two, five) = (
            pre.get(1).unwrap(),
            pre.get(6).unwrap(),
            pre.get(7).unwrap(),
        );
        let mut dst = Lobes::default();
        for src in [one, five, two, one, five, five, two] {
            let spilled_before = dst.as_slice().len() > 2;
            let storage = dst.as_slice().as_ptr();
            dst.clone_from(src);
            assert_eq!(dst, *src);
            assert_eq!(dst, src.clone());
            if spilled_before {
                assert_eq!(dst.as_slice().as_ptr(), storage, "spilled storage kept");
            }
        }
    }

    /// A copy skipped because the list already holds the same table entry's copy leaves it equal
    /// to that entry; a list changed since, or holding an entry of another table (another
    /// scene's) under the same material number, is copied again. Fails when a change to the
    /// list does not clear its mark (`clear` below, `material::build`), or when tables share
    /// marks.
    #[test]
    fn a_skipped_copy_is_the_entry_it_skipped() {
        let (m, t) = (materials(), vec![checker(1.0)]);
        let pre = PrebuiltLobes::new(&m, &t);
        let (matte, metal) = (pre.get(1).unwrap(), pre.get(3).unwrap());
        let mut dst = Lobes::default();
        dst.clone_from(matte);
        dst.clone_from(matte);
        assert_eq!(dst, *matte);
        // Changed in place: the next copy of the same entry must replace it.
        material::build(&mut dst, &m, &t, 3, [0.0; 2]).unwrap();
        assert_eq!(dst, *metal);
        dst.clone_from(matte);
        assert_eq!(dst, *matte, "a changed list was taken for the entry's copy");
        dst.clear();
        dst.clone_from(matte);
        assert_eq!(dst, *matte, "a cleared list was taken for the entry's copy");
        // Another scene's table, whose material 1 is the metal.
        let other = PrebuiltLobes::new(&[m[0].clone(), m[3].clone()], &t);
        dst.clone_from(other.get(1).unwrap());
        assert_eq!(
            dst, *metal,
            "another table's entry was taken for this one's"
        );
        dst.clone_from(matte);
        assert_eq!(dst, *matte);
    }
}
