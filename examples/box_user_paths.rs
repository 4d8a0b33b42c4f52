//! Make the user paths of the built-in `box` scene (Fan, Chenney & Lai 2005, §5.1 and Figure 5):
//! rays from the light aimed at the glass ball, directly (five paths: the large caustic under the
//! ball) and through the mirror wall (five paths: the small caustic), followed through their
//! specular bounces to the first diffuse surface, printed in the `--user-paths` format — what the
//! paper's interactive tool did by hand. The segments leaving the light get β = 5°, and the first
//! segment of a path through the mirror β = 1°, as in the paper.
//!
//! `cargo run --release --example box_user_paths > examples/box.user-paths`

use light_transport::bsdf::TransportMode;
use light_transport::geometry::{Ray, offset_origin};
use light_transport::math::DVec3;
use light_transport::scene::photon_scenes::BOX_GLASS_BALL;
use light_transport::scene::{Scene, builtin};

/// Follow the ray from `from` toward `aim` through specular surfaces: the points of the path
/// (the light point first), ending at the first surface that scatters diffusely.
fn follow(scene: &Scene, from: DVec3, aim: DVec3) -> Option<Vec<(DVec3, bool)>> {
    let mut points = vec![(from, false)];
    let mut o = from;
    let mut w = (aim - from).normalize();
    for _ in 0..8 {
        let hit = scene.intersect(&Ray::new(o, w))?;
        let p = hit.point.p;
        let bsdf = scene.bsdf(&hit.point).ok()?;
        if !bsdf.is_delta_only() {
            points.push((p, false));
            return Some(points);
        }
        // Refract when the surface transmits (glass), reflect otherwise (mirror).
        let transmit = bsdf.delta_direction(-w, true, TransportMode::Importance);
        let next =
            transmit.or_else(|| bsdf.delta_direction(-w, false, TransportMode::Importance))?;
        points.push((p, true));
        o = offset_origin(p, hit.point.n, next);
        w = next;
    }
    None
}

fn main() {
    let scene = Scene::new(&builtin::builtin("box").expect("box"), None).expect("scene");
    let light = DVec3::new(-0.005, 1.979, -0.03);
    let (c, r) = BOX_GLASS_BALL;
    println!("# User paths of the built-in `box` scene: light → glass ball → floor (the large");
    println!("# caustic) and light → mirror wall → glass ball → floor (the small one).");
    println!("# Made by `cargo run --release --example box_user_paths`; format: see");
    println!(
        "# light_transport::pathspace::user_path. One point per line, `x y z [β in degrees]`."
    );
    let offsets = [
        DVec3::new(0.0, 0.0, 0.0),
        DVec3::new(0.12, 0.05, 0.0),
        DVec3::new(-0.12, 0.05, 0.0),
        DVec3::new(0.0, 0.05, 0.12),
        DVec3::new(0.0, 0.05, -0.12),
    ];
    for (mirror, beta) in [(false, 5.0), (true, 1.0)] {
        for o in offsets {
            // Through the mirror x = 1: aim at the ball's mirror image.
            let target = c + o * r;
            let aim = if mirror {
                DVec3::new(2.0 - target.x, target.y, target.z)
            } else {
                target
            };
            let Some(points) = follow(&scene, light, aim) else {
                eprintln!("no path toward {aim:?}");
                continue;
            };
            println!("path beta=5");
            for (i, (p, _)) in points.iter().enumerate() {
                if i == 1 {
                    println!("{:.6} {:.6} {:.6} {beta}", p.x, p.y, p.z);
                } else {
                    println!("{:.6} {:.6} {:.6}", p.x, p.y, p.z);
                }
            }
        }
    }
}
