//! The built-in scenes of Metropolis photon sampling's situations (Fan, Chenney & Lai 2005):
//!
//! * `rooms` — two rooms side by side behind a thin divider with a doorway; the bright light is in
//!   the far room, the camera faces the divider (the doorway is out of view, near the back
//!   corner), and the camera's room has a small dim lamp. Almost all the power a photon tracer
//!   sends stays in the far room, whose floor continues under the divider with the same
//!   orientation as the near room's: photon lookups at the base of the divider bleed it through
//!   (their Figure 1);
//! * `lantern` — a lidded box with three small windows around the light, on a table in a room: the
//!   box catches most of the photons a light tracer sends (their Figure 4);
//! * `box` — a Cornell box whose right wall is a mirror, with a mirror ball at the back and a glass
//!   ball in front: caustics under the glass ball, one of them of light reflected by the mirror
//!   wall first (their Figure 5). `examples/box.user-paths` holds ten user paths for its caustics
//!   (made by `cargo run --release --example box_user_paths`).

use super::builtin::SceneBuilder;
use super::description::{MaterialDesc, SceneDescription};
use crate::math::DVec3;
use crate::spectrum::Rgb;

/// Names of these scenes.
pub const PHOTON_SCENES: [&str; 3] = ["rooms", "lantern", "box"];

/// The divider of `rooms` is the plane `x = 0` (thickness 2 cm); its doorway spans this range of
/// `z` up to `DOOR_TOP`.
pub const ROOMS_DOOR: [f64; 2] = [-1.9, -1.2];
/// Height of the doorway of `rooms`.
pub const ROOMS_DOOR_TOP: f64 = 1.9;

/// The two rooms (`x < 0` lit brightly, `x > 0` seen by the camera).
pub fn rooms() -> SceneDescription {
    let mut s = SceneBuilder::new(
        240,
        180,
        DVec3::new(2.8, 1.2, 0.5),
        DVec3::new(0.0, 0.8, 0.5),
        45.0,
    );
    let white = s.matte(0.7, 0.7, 0.68);
    let floor = s.matte(0.6, 0.52, 0.42);
    let blue = s.matte(0.2, 0.3, 0.6);
    let black = s.matte(0.0, 0.0, 0.0);
    let (x0, x1, z0, z1, h) = (-3.5, 3.0, -2.0, 2.0, 2.4);
    // One floor and one ceiling under both rooms.
    s.quad(
        DVec3::new(x0, 0.0, z0),
        DVec3::Z * (z1 - z0),
        DVec3::X * (x1 - x0),
        floor,
        None,
    );
    s.quad(
        DVec3::new(x0, h, z0),
        DVec3::X * (x1 - x0),
        DVec3::Z * (z1 - z0),
        white,
        None,
    );
    // Outer walls, facing in.
    s.quad(
        DVec3::new(x0, 0.0, z0),
        DVec3::X * (x1 - x0),
        DVec3::Y * h,
        white,
        None,
    ); // back
    s.quad(
        DVec3::new(x0, 0.0, z1),
        DVec3::Y * h,
        DVec3::X * (x1 - x0),
        white,
        None,
    ); // front
    s.quad(
        DVec3::new(x0, 0.0, z0),
        DVec3::Y * h,
        DVec3::Z * (z1 - z0),
        white,
        None,
    ); // left
    s.quad(
        DVec3::new(x1, 0.0, z0),
        DVec3::Z * (z1 - z0),
        DVec3::Y * h,
        white,
        None,
    ); // right
    // The divider, 2 cm thick, with its doorway.
    let t = 0.01;
    let [d0, d1] = ROOMS_DOOR;
    s.cuboid(DVec3::new(-t, 0.0, z0), DVec3::new(t, h, d0), white);
    s.cuboid(DVec3::new(-t, 0.0, d1), DVec3::new(t, h, z1), white);
    s.cuboid(
        DVec3::new(-t, ROOMS_DOOR_TOP, d0),
        DVec3::new(t, h, d1),
        white,
    );
    // A cabinet in the near room.
    s.cuboid(DVec3::new(0.6, 0.0, 0.9), DVec3::new(1.2, 0.7, 1.5), blue);
    // The bright light of the far room, and the near room's dim lamp (2.7% of the power).
    s.quad(
        DVec3::new(-2.1, h - 0.01, -0.3),
        DVec3::X * 0.6,
        DVec3::Z * 0.6,
        black,
        Some(Rgb::new(80.0, 72.0, 60.0)),
    );
    s.quad(
        DVec3::new(2.2, h - 0.01, 1.2),
        DVec3::X * 0.2,
        DVec3::Z * 0.2,
        black,
        Some(Rgb::new(20.0, 20.0, 20.0)),
    );
    s.finish()
}

/// A square face `p, p + a, p + a + b, p + b` (normal along `a × b`) with a square window of
/// side `w` at its centre, as four quads.
fn face_with_window(s: &mut SceneBuilder, p: DVec3, a: DVec3, b: DVec3, w: f64, material: usize) {
    let (la, lb) = (a.length(), b.length());
    let (ua, ub) = (a / la, b / lb);
    let (fa, fb) = ((la - w) / 2.0, (lb - w) / 2.0);
    s.quad(p, a, ub * fb, material, None); // bottom strip
    s.quad(p + ub * (fb + w), a, ub * fb, material, None); // top strip
    s.quad(p + ub * fb, ua * fa, ub * w, material, None); // left of the window
    s.quad(p + ub * fb + ua * (fa + w), ua * fa, ub * w, material, None); // right
}

/// The lantern on a table in a room.
pub fn lantern() -> SceneDescription {
    let mut s = SceneBuilder::new(
        240,
        180,
        DVec3::new(1.9, 1.55, 2.3),
        DVec3::new(0.0, 0.85, 0.0),
        55.0,
    );
    let white = s.matte(0.72, 0.7, 0.66);
    let floor = s.matte(0.45, 0.4, 0.35);
    let wood = s.matte(0.55, 0.35, 0.2);
    let shell = s.matte(0.8, 0.45, 0.12);
    let black = s.matte(0.0, 0.0, 0.0);
    let (r, h) = (2.5, 2.5);
    s.quad(
        DVec3::new(-r, 0.0, -r),
        DVec3::Z * 2.0 * r,
        DVec3::X * 2.0 * r,
        floor,
        None,
    );
    s.quad(
        DVec3::new(-r, h, -r),
        DVec3::X * 2.0 * r,
        DVec3::Z * 2.0 * r,
        white,
        None,
    );
    s.quad(
        DVec3::new(-r, 0.0, -r),
        DVec3::X * 2.0 * r,
        DVec3::Y * h,
        white,
        None,
    );
    s.quad(
        DVec3::new(-r, 0.0, r),
        DVec3::Y * h,
        DVec3::X * 2.0 * r,
        white,
        None,
    );
    s.quad(
        DVec3::new(-r, 0.0, -r),
        DVec3::Y * h,
        DVec3::Z * 2.0 * r,
        white,
        None,
    );
    s.quad(
        DVec3::new(r, 0.0, -r),
        DVec3::Z * 2.0 * r,
        DVec3::Y * h,
        white,
        None,
    );
    // The table.
    let top = 0.76;
    s.cuboid(DVec3::new(-0.8, 0.0, -0.6), DVec3::new(0.8, top, 0.6), wood);
    // The lantern: a 0.5 m box with windows of 20 cm in its front and side faces.
    let (c, e, w) = (0.25, 0.5, 0.2);
    let lo = DVec3::new(-c, top, -c);
    face_with_window(
        &mut s,
        lo + DVec3::Z * e,
        DVec3::X * e,
        DVec3::Y * e,
        w,
        shell,
    ); // front (+z)
    face_with_window(&mut s, lo, DVec3::Z * e, DVec3::Y * e, w, shell); // left (−x): Z × Y = −x
    face_with_window(
        &mut s,
        lo + DVec3::X * e,
        DVec3::Y * e,
        DVec3::Z * e,
        w,
        shell,
    ); // right (+x)
    s.quad(lo, DVec3::X * e, DVec3::Y * e, shell, None); // back (−z)
    s.quad(lo + DVec3::Y * e, DVec3::X * e, DVec3::Z * e, shell, None); // lid (outward normal −y
    // inside: the lid's underside faces the light)
    // The light, just under the lid, facing down.
    s.quad(
        DVec3::new(-0.08, top + e - 0.01, -0.08),
        DVec3::X * 0.16,
        DVec3::Z * 0.16,
        black,
        Some(Rgb::new(300.0, 240.0, 150.0)),
    );
    s.finish()
}

/// The Cornell box with a mirror wall, a mirror ball and a glass ball.
pub fn mirror_box() -> SceneDescription {
    let mut s = SceneBuilder::new(
        256,
        256,
        DVec3::new(0.0, 1.0, 6.8),
        DVec3::new(0.0, 1.0, 0.0),
        19.5,
    );
    let white = s.matte(0.725, 0.71, 0.68);
    let red = s.matte(0.63, 0.065, 0.05);
    let black = s.matte(0.0, 0.0, 0.0);
    let mirror = s.material(MaterialDesc::Mirror {
        kr: Rgb::splat(0.95),
    });
    let glass = s.material(MaterialDesc::Glass {
        eta: 1.5,
        alpha_u: 0.0,
        alpha_v: 0.0,
        kr: Rgb::WHITE,
        kt: Rgb::WHITE,
    });
    s.cornell_walls([white, white, white, red, mirror]); // the right wall is a mirror
    s.quad(
        DVec3::new(-0.24, 1.98, -0.22),
        DVec3::X * 0.47,
        DVec3::Z * 0.38,
        black,
        Some(Rgb::new(17.0, 12.0, 4.0)),
    );
    s.sphere(BOX_MIRROR_BALL.0, BOX_MIRROR_BALL.1, mirror);
    s.sphere(BOX_GLASS_BALL.0, BOX_GLASS_BALL.1, glass);
    s.finish()
}

/// Centre and radius of the mirror ball of `box`.
pub const BOX_MIRROR_BALL: (DVec3, f64) = (DVec3::new(-0.45, 0.35, -0.45), 0.35);
/// Centre and radius of the glass ball of `box`.
pub const BOX_GLASS_BALL: (DVec3, f64) = (DVec3::new(0.3, 0.35, 0.25), 0.35);
