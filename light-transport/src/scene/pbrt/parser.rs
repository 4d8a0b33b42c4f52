//! The directive interpreter: reads directives from a stack of files (`Include`), keeps the current
//! transformation and the graphics-state stack, checks where each directive may appear (options
//! before `WorldBegin`, scene description inside the world block) and hands shapes, materials,
//! textures, lights and the camera to their modules.

use super::camera;
use super::lights;
use super::materials::{self, MaterialScope};
use super::params::{self, ParamList};
use super::shapes::{self, ShapeContext};
use super::state::{Block, BlockKind, GraphicsState};
use super::textures::{self, NamedTexture, TextureStore};
use super::tokenizer::{Token, TokenKind, Tokenizer};
use super::transform;
use crate::error::{Error, Location, Result};
use crate::math::{DMat4, DVec3};
use crate::scene::description::{MaterialDesc, RgbTexture, SceneDescription};
use crate::spectrum::Rgb;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::rc::Rc;

/// Deepest accepted nesting of `Include`.
const MAX_INCLUDE_DEPTH: usize = 64;

/// Directives that only choose pbrt's own rendering machinery.
const MACHINERY: &[&str] = &[
    "Integrator",
    "SurfaceIntegrator",
    "VolumeIntegrator",
    "Sampler",
    "PixelFilter",
    "Accelerator",
    "Renderer",
];

/// One file being read.
struct Frame {
    tok: Tokenizer,
    /// Directory that relative names in this file are resolved against.
    dir: PathBuf,
    /// Identity of the file for cycle detection (canonical path when it exists).
    key: PathBuf,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    Options,
    World,
    Ended,
}

/// The state of one load.
pub(crate) struct Loader {
    files: Vec<Frame>,
    desc: SceneDescription,
    state: GraphicsState,
    blocks: Vec<Block>,
    coordinate_systems: HashMap<String, DMat4>,
    phase: Phase,
    default_material: Option<usize>,
    store: TextureStore,
    camera_at: Option<Location>,
    film_at: Option<Location>,
    end_of_main: Option<Location>,
}

impl Loader {
    /// A loader for the top-level file `file` holding `text`; relative names resolve against `dir`
    /// and `key` identifies the file for include-cycle detection.
    pub fn new(text: String, file: PathBuf, dir: PathBuf, key: PathBuf) -> Self {
        let mut desc = SceneDescription::default();
        desc.film.width = camera::DEFAULT_FILM.0;
        desc.film.height = camera::DEFAULT_FILM.1;
        Self {
            files: vec![Frame {
                tok: Tokenizer::new(text, file),
                dir,
                key,
            }],
            desc,
            state: GraphicsState::default(),
            blocks: Vec::new(),
            coordinate_systems: HashMap::new(),
            phase: Phase::Options,
            default_material: None,
            store: TextureStore::default(),
            camera_at: None,
            film_at: None,
            end_of_main: None,
        }
    }

    /// Read every directive and return the scene.
    pub fn run(mut self) -> Result<SceneDescription> {
        let mut depth = self.files.len();
        while let Some(frame) = self.files.last_mut() {
            match frame.tok.next_token()? {
                Some(t) => self.directive(t)?,
                None => {
                    if depth == 1 {
                        self.end_of_main = Some(frame.tok.end_location());
                    }
                    self.files.pop();
                }
            }
            depth = self.files.len();
        }
        self.finish()
    }

    fn finish(mut self) -> Result<SceneDescription> {
        let eof = self.end_of_main.clone().unwrap_or_else(|| Location {
            file: PathBuf::new(),
            line: 0,
        });
        if let Some(b) = self.blocks.last() {
            return Err(Error::scene(
                &b.opened,
                format!("{} is never closed by {}", b.kind.begin(), b.kind.end()),
            ));
        }
        if self.phase == Phase::Options {
            return Err(Error::scene(
                &eof,
                "the file ends without WorldBegin: there is no scene",
            ));
        }
        if self.desc.camera.is_none() {
            self.desc.camera = camera::default_camera(&DMat4::IDENTITY);
            self.desc.warnings.push((
                "no Camera directive: using pbrt's default perspective camera (fov 90°) at the \
                 origin looking down +z"
                    .into(),
                eof,
            ));
        }
        self.desc.textures = std::mem::take(&mut self.store.textures);
        Ok(self.desc)
    }

    // ---- token helpers -------------------------------------------------------------------

    fn tok(&mut self) -> Result<&mut Tokenizer> {
        self.files
            .last_mut()
            .map(|f| &mut f.tok)
            .ok_or_else(|| Error::InvalidScene("no file is being read".into()))
    }

    fn dir(&self) -> PathBuf {
        self.files.last().map(|f| f.dir.clone()).unwrap_or_default()
    }

    fn location(&self, line: usize) -> Location {
        match self.files.last() {
            Some(f) => f.tok.location(line),
            None => Location {
                file: PathBuf::new(),
                line,
            },
        }
    }

    /// The next token of the current file, as an argument of `directive`.
    fn arg(&mut self, directive: &Token, what: &str) -> Result<Token> {
        let loc = self.location(directive.line);
        self.tok()?.next_token()?.ok_or_else(|| {
            Error::scene(
                &loc,
                format!("{} expects {what}, but the file ends", directive.text),
            )
        })
    }

    fn string_arg(&mut self, directive: &Token, what: &str) -> Result<String> {
        let t = self.arg(directive, what)?;
        if t.kind != TokenKind::Str {
            return Err(Error::scene(
                &self.location(t.line),
                format!(
                    "{} expects {what} (a quoted string), found {}",
                    directive.text,
                    t.describe()
                ),
            ));
        }
        Ok(t.text)
    }

    fn number_arg(&mut self, directive: &Token) -> Result<f64> {
        let t = self.arg(directive, "a number")?;
        (t.kind == TokenKind::Bare)
            .then(|| params::parse_real(&t.text))
            .flatten()
            .ok_or_else(|| {
                Error::scene(
                    &self.location(t.line),
                    format!(
                        "{} expects a finite number, found {}",
                        directive.text,
                        t.describe()
                    ),
                )
            })
    }

    fn numbers<const N: usize>(&mut self, directive: &Token) -> Result<[f64; N]> {
        let mut out = [0.0; N];
        for v in &mut out {
            *v = self.number_arg(directive)?;
        }
        Ok(out)
    }

    /// `[ m00 … m33 ]` (brackets optional).
    fn matrix_arg(&mut self, directive: &Token) -> Result<DMat4> {
        let bracket = matches!(
            self.tok()?.peek()?,
            Some(Token {
                kind: TokenKind::Open,
                ..
            })
        );
        if bracket {
            self.tok()?.next_token()?;
        }
        let m = self.numbers::<16>(directive)?;
        if bracket {
            let t = self.arg(directive, "`]`")?;
            if t.kind != TokenKind::Close {
                return Err(Error::scene(
                    &self.location(t.line),
                    format!(
                        "{} takes exactly 16 numbers; expected `]`, found {}",
                        directive.text,
                        t.describe()
                    ),
                ));
            }
        }
        Ok(transform::from_pbrt(&m))
    }

    fn param_list(&mut self, at: &Location) -> Result<ParamList> {
        let tok = self.tok()?;
        params::parse_list(tok, at.clone())
    }

    // ---- directives ----------------------------------------------------------------------

    fn require(&self, name: &str, at: &Location, phase: Phase) -> Result<()> {
        if self.phase == phase {
            return Ok(());
        }
        Err(Error::scene(
            at,
            match phase {
                Phase::Options => {
                    format!("{name} is only allowed before WorldBegin (it is a rendering option)")
                }
                _ => format!("{name} is only allowed between WorldBegin and WorldEnd"),
            },
        ))
    }

    fn directive(&mut self, t: Token) -> Result<()> {
        let at = self.location(t.line);
        if t.kind != TokenKind::Bare {
            return Err(Error::scene(
                &at,
                format!("expected a directive, found {}", t.describe()),
            ));
        }
        let name = t.text.as_str();
        if self.phase == Phase::Ended {
            return Err(Error::scene(
                &at,
                format!("{name} after WorldEnd (only one scene per file is supported)"),
            ));
        }
        match name {
            "Identity" => self.state.ctm = DMat4::IDENTITY,
            "Translate" => {
                let [x, y, z] = self.numbers(&t)?;
                self.state.ctm *= transform::translate(DVec3::new(x, y, z));
            }
            "Scale" => {
                let [x, y, z] = self.numbers(&t)?;
                self.state.ctm *= transform::scale(DVec3::new(x, y, z));
            }
            "Rotate" => {
                let [a, x, y, z] = self.numbers(&t)?;
                let r = transform::rotate(a, DVec3::new(x, y, z))
                    .ok_or_else(|| Error::scene(&at, "Rotate about a zero axis"))?;
                self.state.ctm *= r;
            }
            "LookAt" => {
                let v: [f64; 9] = self.numbers(&t)?;
                let m = transform::look_at(
                    DVec3::new(v[0], v[1], v[2]),
                    DVec3::new(v[3], v[4], v[5]),
                    DVec3::new(v[6], v[7], v[8]),
                )
                .map_err(|e| Error::scene(&at, format!("LookAt: {e}")))?;
                self.state.ctm *= m;
            }
            "Transform" => self.state.ctm = self.matrix_arg(&t)?,
            "ConcatTransform" => {
                let m = self.matrix_arg(&t)?;
                self.state.ctm *= m;
            }
            "CoordinateSystem" => {
                let n = self.string_arg(&t, "a name")?;
                self.coordinate_systems.insert(n, self.state.ctm);
            }
            "CoordSysTransform" => {
                let n = self.string_arg(&t, "a name")?;
                self.state.ctm = *self.coordinate_systems.get(&n).ok_or_else(|| {
                    Error::scene(
                        &at,
                        format!("CoordSysTransform: unknown coordinate system \"{n}\""),
                    )
                })?;
            }
            "ActiveTransform" => {
                let w = self.arg(&t, "All, StartTime or EndTime")?;
                if w.text != "All" {
                    return Err(Error::scene(
                        &at,
                        format!("ActiveTransform {}: motion blur is not supported", w.text),
                    ));
                }
            }
            "TransformTimes" => {
                self.numbers::<2>(&t)?;
                self.desc.ignored.push(("TransformTimes".into(), at));
            }
            "TransformBegin" | "AttributeBegin" => {
                let kind = if name == "AttributeBegin" {
                    self.require(name, &at, Phase::World)?;
                    BlockKind::Attribute
                } else {
                    BlockKind::Transform
                };
                self.blocks.push(Block {
                    kind,
                    opened: at,
                    saved: self.state.clone(),
                });
            }
            "TransformEnd" | "AttributeEnd" => {
                let kind = if name == "AttributeEnd" {
                    BlockKind::Attribute
                } else {
                    BlockKind::Transform
                };
                let Some(b) = self.blocks.pop() else {
                    return Err(Error::scene(
                        &at,
                        format!("{name} without a matching {}", kind.begin()),
                    ));
                };
                if b.kind != kind {
                    return Err(Error::scene(
                        &at,
                        format!(
                            "{name} closes the {} opened at {}",
                            b.kind.begin(),
                            b.opened
                        ),
                    ));
                }
                match kind {
                    BlockKind::Attribute => self.state = b.saved,
                    BlockKind::Transform => self.state.ctm = b.saved.ctm,
                }
            }
            "ReverseOrientation" => {
                self.require(name, &at, Phase::World)?;
                self.state.reverse_orientation = !self.state.reverse_orientation;
            }
            "WorldBegin" => {
                self.require(name, &at, Phase::Options)?;
                if let Some(b) = self.blocks.last() {
                    return Err(Error::scene(
                        &at,
                        format!(
                            "WorldBegin inside the {} opened at {}",
                            b.kind.begin(),
                            b.opened
                        ),
                    ));
                }
                self.phase = Phase::World;
                self.state.ctm = DMat4::IDENTITY;
                self.coordinate_systems
                    .insert("world".into(), DMat4::IDENTITY);
            }
            "WorldEnd" => {
                self.require(name, &at, Phase::World)?;
                if let Some(b) = self.blocks.last() {
                    return Err(Error::scene(
                        &at,
                        format!(
                            "WorldEnd while the {} opened at {} is still open",
                            b.kind.begin(),
                            b.opened
                        ),
                    ));
                }
                self.phase = Phase::Ended;
            }
            "Include" | "Import" => {
                let file = self.string_arg(&t, "a file name")?;
                self.include(&file, &at)?;
            }
            "Camera" => {
                self.require(name, &at, Phase::Options)?;
                let kind = self.string_arg(&t, "a camera type")?;
                let p = self.param_list(&at)?;
                let cam = camera::camera(&kind, &p, &self.state.ctm)?;
                if let Some(prev) = self.camera_at.replace(at.clone()) {
                    self.desc
                        .warnings
                        .push((format!("a second Camera replaces the one at {prev}"), at));
                }
                self.coordinate_systems
                    .insert("camera".into(), cam.camera_to_world);
                self.desc.camera = Some(cam);
            }
            "Film" => {
                self.require(name, &at, Phase::Options)?;
                let kind = self.string_arg(&t, "a film type")?;
                let p = self.param_list(&at)?;
                self.desc.film = camera::film(&kind, &p)?;
                if let Some(prev) = self.film_at.replace(at.clone()) {
                    self.desc
                        .warnings
                        .push((format!("a second Film replaces the one at {prev}"), at));
                }
            }
            _ if MACHINERY.contains(&name) => {
                self.require(name, &at, Phase::Options)?;
                let kind = self.string_arg(&t, "a type")?;
                self.param_list(&at)?;
                self.desc.ignored.push((format!("{name} \"{kind}\""), at));
            }
            "Option" => {
                self.param_list(&at)?;
                self.desc.ignored.push(("Option".into(), at));
            }
            "ColorSpace" => {
                let cs = self.string_arg(&t, "a colour space")?;
                if cs != "srgb" {
                    return Err(Error::scene(
                        &at,
                        format!("ColorSpace \"{cs}\" is not supported (only \"srgb\")"),
                    ));
                }
                self.desc.ignored.push(("ColorSpace \"srgb\"".into(), at));
            }
            "MediumInterface" => {
                let inside = self.string_arg(&t, "a medium name")?;
                let outside = match self.tok()?.peek()? {
                    Some(Token {
                        kind: TokenKind::Str,
                        ..
                    }) => self.string_arg(&t, "a medium name")?,
                    _ => inside.clone(),
                };
                if !inside.is_empty() || !outside.is_empty() {
                    return Err(Error::scene(&at, "participating media are not supported"));
                }
                self.desc
                    .ignored
                    .push(("MediumInterface \"\" \"\"".into(), at));
            }
            "MakeNamedMedium" => {
                return Err(Error::scene(&at, "participating media are not supported"));
            }
            "ObjectBegin" | "ObjectEnd" | "ObjectInstance" => {
                return Err(Error::scene(
                    &at,
                    format!("{name}: object instancing is not supported"),
                ));
            }
            "Material" => {
                self.require(name, &at, Phase::World)?;
                let kind = self.string_arg(&t, "a material type")?;
                let p = self.param_list(&at)?;
                let m = self.build_material(&kind, &p, &format!("Material \"{kind}\""))?;
                self.desc.materials.push(m);
                self.state.material = Some(self.desc.materials.len() - 1);
            }
            "MakeNamedMaterial" => {
                self.require(name, &at, Phase::World)?;
                let mname = self.string_arg(&t, "a material name")?;
                let p = self.param_list(&at)?;
                let kind = p.string("type")?.ok_or_else(|| {
                    Error::scene(
                        &at,
                        format!("MakeNamedMaterial \"{mname}\" needs \"string type\""),
                    )
                })?;
                let m = self.build_material(
                    kind,
                    &p,
                    &format!("MakeNamedMaterial \"{mname}\" (type \"{kind}\")"),
                )?;
                self.desc.materials.push(m);
                let idx = self.desc.materials.len() - 1;
                Rc::make_mut(&mut self.state.named_materials).insert(mname, idx);
            }
            "NamedMaterial" => {
                self.require(name, &at, Phase::World)?;
                let mname = self.string_arg(&t, "a material name")?;
                let idx = *self.state.named_materials.get(&mname).ok_or_else(|| {
                    Error::scene(&at, format!("NamedMaterial: unknown material \"{mname}\""))
                })?;
                self.state.material = Some(idx);
            }
            "Texture" => {
                self.require(name, &at, Phase::World)?;
                let tname = self.string_arg(&t, "a texture name")?;
                let ty = self.string_arg(&t, "a texture type")?;
                let class = self.string_arg(&t, "a texture class")?;
                let p = self.param_list(&at)?;
                let dir = self.dir();
                let tex = textures::texture(
                    &ty,
                    &class,
                    &p,
                    &dir,
                    &self.state.rgb_textures,
                    &self.state.float_textures,
                    &mut self.store,
                )?;
                match tex {
                    NamedTexture::Rgb(r) => {
                        Rc::make_mut(&mut self.state.rgb_textures).insert(tname, r);
                    }
                    NamedTexture::Float(f) => {
                        Rc::make_mut(&mut self.state.float_textures).insert(tname, f);
                    }
                }
            }
            "LightSource" => {
                self.require(name, &at, Phase::World)?;
                let kind = self.string_arg(&t, "a light type")?;
                let p = self.param_list(&at)?;
                let l = lights::light_source(&kind, &p, &self.state.ctm, &mut self.desc.warnings)?;
                self.desc.lights.push(l);
            }
            "AreaLightSource" => {
                self.require(name, &at, Phase::World)?;
                let kind = self.string_arg(&t, "an area light type")?;
                let p = self.param_list(&at)?;
                self.state.area_light = Some(lights::area_light(&kind, &p)?);
            }
            "Shape" => {
                self.require(name, &at, Phase::World)?;
                let kind = self.string_arg(&t, "a shape type")?;
                let p = self.param_list(&at)?;
                let material = self.current_material();
                let dir = self.dir();
                let ctx = ShapeContext {
                    ctm: self.state.ctm,
                    reverse_orientation: self.state.reverse_orientation,
                    material,
                    area_light: self.state.area_light,
                    location: at,
                    dir: &dir,
                };
                shapes::shape(&kind, &p, &ctx, &mut self.desc)?;
            }
            _ => {
                return Err(Error::scene(
                    &at,
                    format!("unknown or unsupported directive `{name}`"),
                ));
            }
        }
        if !self.state.ctm.is_finite() {
            return Err(Error::scene(
                &self.location(t.line),
                format!("{name} makes the current transformation non-finite (overflow)"),
            ));
        }
        Ok(())
    }

    fn build_material(&self, kind: &str, p: &ParamList, what: &str) -> Result<MaterialDesc> {
        let scope = MaterialScope {
            named: &self.state.named_materials,
            rgb_textures: &self.state.rgb_textures,
            float_textures: &self.state.float_textures,
        };
        materials::material(kind, p, &scope, what)
    }

    /// The current material, creating pbrt's default (matte, `Kd` 0.5) on first need.
    fn current_material(&mut self) -> usize {
        if let Some(m) = self.state.material {
            return m;
        }
        *self.default_material.get_or_insert_with(|| {
            self.desc.materials.push(MaterialDesc::Matte {
                kd: RgbTexture::Constant(Rgb::splat(0.5)),
            });
            self.desc.materials.len() - 1
        })
    }

    fn include(&mut self, file: &str, at: &Location) -> Result<()> {
        let path = self.dir().join(file);
        let fail = |e: &dyn std::fmt::Display| {
            Error::scene(
                at,
                format!("cannot read included file {}: {e}", path.display()),
            )
        };
        let key = std::fs::canonicalize(&path).map_err(|e| fail(&e))?;
        if let Some(i) = self.files.iter().position(|f| f.key == key) {
            let chain: Vec<String> = self.files[i..]
                .iter()
                .map(|f| f.tok.file().display().to_string())
                .chain(std::iter::once(path.display().to_string()))
                .collect();
            return Err(Error::scene(
                at,
                format!("Include cycle: {}", chain.join(" → ")),
            ));
        }
        if self.files.len() >= MAX_INCLUDE_DEPTH {
            return Err(Error::scene(
                at,
                format!("Include nested deeper than {MAX_INCLUDE_DEPTH} files"),
            ));
        }
        let bytes = std::fs::read(&path).map_err(|e| fail(&e))?;
        let text = super::tokenizer::text_of(bytes);
        let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        self.files.push(Frame {
            tok: Tokenizer::new(text, path),
            dir,
            key,
        });
        Ok(())
    }
}
