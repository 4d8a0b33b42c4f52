//! Resolving a scene argument: a built-in name or a pbrt-v3 file.

use super::CliError;
use light_transport::accel::Compact;
use light_transport::scene::{Scene, SceneDescription, builtin};
use std::path::Path;
use std::time::{Duration, Instant};

/// A loaded scene with its display name and load time.
pub struct Loaded {
    /// Short name for file names and reports.
    pub name: String,
    /// The description.
    pub description: SceneDescription,
    /// Time spent parsing.
    pub parse_time: Duration,
}

/// Load `arg`: a built-in scene name (`cornell`, `caustic`, `door`) or a path to a `.pbrt` file.
pub fn load(arg: &str) -> Result<Loaded, CliError> {
    let t = Instant::now();
    if let Some(d) = builtin::builtin(arg) {
        return Ok(Loaded {
            name: arg.to_string(),
            description: d,
            parse_time: t.elapsed(),
        });
    }
    let path = Path::new(arg);
    if !path.exists() {
        return Err(CliError::Usage(format!(
            "no scene {arg:?}: not a file and not a built-in scene (built-in: {})",
            builtin::all().join(", ")
        )));
    }
    let description = light_transport::scene::pbrt::load(path)?;
    let name = path
        .parent()
        .and_then(|p| p.file_name())
        .filter(|_| path.file_stem().is_some_and(|s| s == "scene"))
        .or_else(|| path.file_stem())
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene".into());
    Ok(Loaded {
        name,
        description,
        parse_time: t.elapsed(),
    })
}

/// Build the renderable scene, optionally at another resolution, its BVH `compact` or not; the
/// description stays.
pub fn build(
    loaded: &Loaded,
    resolution: Option<(usize, usize)>,
    compact: Compact,
) -> Result<(Scene, Duration), CliError> {
    let t = Instant::now();
    let scene = Scene::with_bvh(&loaded.description, resolution, compact)?;
    Ok((scene, t.elapsed()))
}

/// As [`build`], taking the description out of `loaded` ([`Scene::from_description`]: a large
/// mesh's description is released before the BVH is finished, which lowers the peak memory).
pub fn build_taking(
    loaded: &mut Loaded,
    resolution: Option<(usize, usize)>,
    compact: Compact,
) -> Result<(Scene, Duration), CliError> {
    let t = Instant::now();
    let description = std::mem::take(&mut loaded.description);
    let scene = Scene::from_description(description, resolution, compact)?;
    Ok((scene, t.elapsed()))
}

/// Parse `WxH`.
pub fn parse_resolution(s: &str) -> Result<(usize, usize), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("bad resolution {s:?}: expected WIDTHxHEIGHT"))?;
    let w: usize = w
        .trim()
        .parse()
        .map_err(|_| format!("bad width in {s:?}"))?;
    let h: usize = h
        .trim()
        .parse()
        .map_err(|_| format!("bad height in {s:?}"))?;
    light_transport::scene::validate_resolution(w, h).map_err(|e| e.to_string())?;
    Ok((w, h))
}
