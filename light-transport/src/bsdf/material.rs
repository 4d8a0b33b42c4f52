//! Building the lobes of a [`super::Bsdf`] from the scene model's [`MaterialDesc`]: parameter
//! validation (errors, never panics), texture lookup, roughness-zero → delta lobes, and the
//! flattening of `mix` materials — `amount · A + (1 − amount) · B` per channel: the lobes of `A`
//! get the factor `amount` and group probability `mean(amount)`, those of `B` get `1 − amount` and
//! `1 − mean(amount)` (nested mixes multiply), all in one list of at most
//! [`super::lobes::MAX_LOBES`] lobes.

use super::conductor::MicrofacetReflection;
use super::dielectric::SmoothDielectric;
use super::fresnel::Fresnel;
use super::lambert::Lambert;
use super::layered::layered_lobes;
use super::lobes::{Lobe, LobeKind, Lobes, MAX_LOBES, Weight};
use super::microfacet::Ggx;
use super::mirror::SpecularReflection;
use super::rough_dielectric::RoughDielectric;
use super::texture;
use crate::error::{Error, Result};
use crate::scene::{MaterialDesc, RgbTexture, TextureDesc};
use crate::spectrum::Rgb;

/// Deepest nesting of mixes (deeper nesting, or a cycle, is an error).
const MAX_DEPTH: usize = 16;

fn invalid(material: usize, reason: impl Into<String>) -> Error {
    Error::InvalidParameter {
        name: format!("material {material}"),
        reason: reason.into(),
    }
}

fn reflectance(material: usize, what: &str, c: Rgb) -> Result<Rgb> {
    if c.0.iter().all(|v| v.is_finite() && *v >= 0.0) {
        Ok(c)
    } else {
        Err(invalid(
            material,
            format!("{what} must be finite and non-negative, got {:?}", c.0),
        ))
    }
}

fn roughness(material: usize, a: f64, b: f64) -> Result<(f64, f64)> {
    if a.is_finite() && b.is_finite() && a >= 0.0 && b >= 0.0 {
        Ok((a, b))
    } else {
        Err(invalid(
            material,
            format!("roughness must be finite and non-negative, got ({a}, {b})"),
        ))
    }
}

fn index(material: usize, eta: f64) -> Result<f64> {
    if eta.is_finite() && eta > 0.0 {
        Ok(eta)
    } else {
        Err(invalid(
            material,
            format!("index of refraction must be finite and positive, got {eta}"),
        ))
    }
}

/// Make `lobes` the lobes of material `material` at texture coordinates `uv`: cleared, the
/// material tree's lobes added, group probabilities normalised. On error `lobes` is unspecified.
pub fn build(
    lobes: &mut Lobes,
    materials: &[MaterialDesc],
    textures: &[TextureDesc],
    material: usize,
    uv: [f64; 2],
) -> Result<()> {
    lobes.clear();
    Builder::new(materials, textures, material, uv, lobes).add(material, Rgb::WHITE, 1.0, 0)?;
    lobes.finish();
    Ok(())
}

/// Whether the lobes of material `m` can differ from one surface point to another: an image
/// texture somewhere in its tree (or a tree [`Builder::add`] rejects, which is then rejected
/// point by point as before).
pub fn varies_over_surface(materials: &[MaterialDesc], m: usize) -> bool {
    fn walk(materials: &[MaterialDesc], m: usize, depth: usize) -> bool {
        let image = |t: &RgbTexture| matches!(t, RgbTexture::Image { .. });
        match materials.get(m) {
            None => true,
            Some(_) if depth > MAX_DEPTH => true,
            Some(MaterialDesc::Matte { kd }) | Some(MaterialDesc::Layered { kd, .. }) => image(kd),
            Some(MaterialDesc::Mix { a, b, .. }) => {
                walk(materials, *a, depth + 1) || walk(materials, *b, depth + 1)
            }
            Some(
                MaterialDesc::Metal { .. }
                | MaterialDesc::Mirror { .. }
                | MaterialDesc::Glass { .. },
            ) => false,
        }
    }
    walk(materials, m, 0)
}

/// Collects lobes while walking the material tree, into a list it borrows (so a BSDF is built in
/// place, without copying its lobes around).
pub struct Builder<'a, 'l> {
    materials: &'a [MaterialDesc],
    textures: &'a [TextureDesc],
    uv: [f64; 2],
    /// The lobes so far.
    pub lobes: &'l mut Lobes,
    root: usize,
}

impl<'a, 'l> Builder<'a, 'l> {
    /// A builder for material `root` at `uv` appending to `lobes`.
    pub fn new(
        materials: &'a [MaterialDesc],
        textures: &'a [TextureDesc],
        root: usize,
        uv: [f64; 2],
        lobes: &'l mut Lobes,
    ) -> Self {
        Self {
            materials,
            textures,
            uv,
            lobes,
            root,
        }
    }

    fn full(&self) -> Error {
        invalid(
            self.root,
            format!("more than {MAX_LOBES} lobes after flattening mixes (nest fewer materials)"),
        )
    }

    fn push_group(&mut self, prob: f64, lobes: &[Option<Lobe>]) -> Result<()> {
        if lobes.iter().all(Option::is_none) {
            return Ok(());
        }
        let group = self.lobes.new_group(prob).ok_or_else(|| self.full())?;
        for l in lobes.iter().flatten() {
            let lobe = Lobe { group, ..*l };
            self.lobes.push(lobe).ok_or_else(|| self.full())?;
        }
        Ok(())
    }

    /// Add the lobes of material `m` with per-channel factor `scale` and group probability `prob`.
    pub fn add(&mut self, m: usize, scale: Rgb, prob: f64, depth: usize) -> Result<()> {
        if depth > MAX_DEPTH {
            return Err(invalid(
                self.root,
                format!("mix nesting deeper than {MAX_DEPTH} (a cycle?)"),
            ));
        }
        let desc = self.materials.get(m).ok_or_else(|| {
            invalid(
                m,
                format!("index out of range ({} materials)", self.materials.len()),
            )
        })?;
        let single = |kind: LobeKind| Lobe {
            kind,
            scale,
            group: 0,
            weight: Weight::Constant(1.0),
        };
        match desc {
            MaterialDesc::Matte { kd } => {
                let kd = reflectance(m, "Kd", texture::evaluate(kd, self.textures, self.uv)?)?;
                let lobe =
                    (kd.average() > 0.0).then(|| single(LobeKind::Lambert(Lambert { r: kd })));
                self.push_group(prob, &[lobe])
            }
            MaterialDesc::Metal {
                eta,
                k,
                alpha_u,
                alpha_v,
            } => {
                let eta = reflectance(m, "eta", *eta)?;
                let k = reflectance(m, "k", *k)?;
                if eta
                    .0
                    .iter()
                    .zip(k.0.iter())
                    .any(|(e, k)| *e == 0.0 && *k == 0.0)
                {
                    return Err(invalid(m, "eta + ik must not be zero"));
                }
                let (au, av) = roughness(m, *alpha_u, *alpha_v)?;
                let fresnel = Fresnel::Conductor { eta, k };
                let kind = if au == 0.0 && av == 0.0 {
                    LobeKind::Specular(SpecularReflection {
                        fresnel,
                        tint: Rgb::WHITE,
                    })
                } else {
                    LobeKind::Glossy(MicrofacetReflection {
                        ggx: Ggx::new(au, av),
                        fresnel,
                        tint: Rgb::WHITE,
                    })
                };
                self.push_group(prob, &[Some(single(kind))])
            }
            MaterialDesc::Mirror { kr } => {
                let kr = reflectance(m, "Kr", *kr)?;
                let lobe = (kr.average() > 0.0).then(|| {
                    single(LobeKind::Specular(SpecularReflection {
                        fresnel: Fresnel::One,
                        tint: kr,
                    }))
                });
                self.push_group(prob, &[lobe])
            }
            MaterialDesc::Glass {
                eta,
                alpha_u,
                alpha_v,
                kr,
                kt,
            } => {
                let eta = index(m, *eta)?;
                let (au, av) = roughness(m, *alpha_u, *alpha_v)?;
                let kr = reflectance(m, "Kr", *kr)?;
                let kt = reflectance(m, "Kt", *kt)?;
                if kr.average() == 0.0 && kt.average() == 0.0 {
                    return Ok(());
                }
                // η = 1: the interface is invisible (straight transmission), a delta lobe even if rough.
                let kind = if (au == 0.0 && av == 0.0) || eta == 1.0 {
                    LobeKind::Dielectric(SmoothDielectric { eta, kr, kt })
                } else {
                    LobeKind::RoughDielectric(RoughDielectric {
                        ggx: Ggx::new(au, av),
                        eta,
                        kr,
                        kt,
                    })
                };
                self.push_group(prob, &[Some(single(kind))])
            }
            MaterialDesc::Layered {
                kd,
                ks,
                alpha_u,
                alpha_v,
                eta,
            } => {
                let kd = reflectance(m, "Kd", texture::evaluate(kd, self.textures, self.uv)?)?;
                let ks = reflectance(m, "Ks", *ks)?;
                let (au, av) = roughness(m, *alpha_u, *alpha_v)?;
                let eta = index(m, *eta)?;
                let lobes = layered_lobes(kd, ks, au, av, eta, scale, 0);
                self.push_group(prob, &lobes)
            }
            MaterialDesc::Mix { a, b, amount } => {
                let amount = reflectance(m, "amount", *amount)?;
                if amount.0.iter().any(|v| *v > 1.0) {
                    return Err(invalid(
                        m,
                        format!("mix amount must lie in [0, 1], got {:?}", amount.0),
                    ));
                }
                let mean = amount.average();
                if mean > 0.0 {
                    self.add(*a, scale * amount, prob * mean, depth + 1)?;
                }
                if mean < 1.0 {
                    self.add(
                        *b,
                        scale * (Rgb::WHITE - amount),
                        prob * (1.0 - mean),
                        depth + 1,
                    )?;
                }
                Ok(())
            }
        }
    }
}
