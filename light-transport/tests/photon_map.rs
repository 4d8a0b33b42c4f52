//! The photon map's radiance estimate (Jensen 2001; Fan, Chenney & Lai 2005, §3) on a uniformly
//! lit diffuse plane, where its exact value is known: photons of equal power `Φ` scattered
//! uniformly over a 2 × 2 square (density `ρ`) give the irradiance `ρΦ` and the Lambertian radiance
//! `(albedo/π) ρΦ`. The cone-filtered estimate over the `k` nearest photons, normalised with the
//! `k`-th photon's distance, is unbiased there (module docs of `photon::map`); the familiar
//! `k/(πr²)` normalisation is biased by `k/(k − 1)` and must be caught.
//!
//! Each check averages 361 queries on a grid whose disks do not overlap (nearly independent), per
//! map, over 16 maps of independent photons, and compares the mean over maps with the exact value
//! by a t-test with 15 degrees of freedom, |t| < 5 (false-positive rate 1.6e-4 per check). Fixed
//! seeds: the verdicts are reproducible.

use light_transport::math::DVec3;
use light_transport::photon::{Lookup, Photon, PhotonMap};
use light_transport::spectrum::Rgb;
use mcmc_core::rng::{stream, uniform};
use std::f64::consts::PI;

const PHOTONS: usize = 200_000;
const POWER: f64 = 2e-5;
const ALBEDO: f64 = 0.6;
const MAPS: u64 = 16;
const T_LIMIT: f64 = 5.0;

/// `count` photons on the square `[0, 2]²` of the plane y = 0 with normal `n` and `power` each.
fn photons(seed: u64, count: usize, n: DVec3, power: f64) -> Vec<Photon> {
    let mut rng = stream(seed, 0);
    (0..count)
        .map(|_| Photon {
            p: DVec3::new(2.0 * uniform(&mut rng), 0.0, 2.0 * uniform(&mut rng)),
            wi: DVec3::new(0.3, 0.9, 0.1).normalize(),
            power: Rgb::splat(power),
            n,
        })
        .collect()
}

/// Mean estimated radiance over the query grid of one map, over its exact value.
fn ratio(map: &PhotonMap, lookup: &Lookup, exact: f64) -> f64 {
    let f = |_: DVec3| Rgb::splat(ALBEDO / PI);
    let mut sum = 0.0;
    let mut n = 0;
    for i in 1..20 {
        for j in 1..20 {
            let x = DVec3::new(0.1 * i as f64, 0.0, 0.1 * j as f64);
            sum += map.estimate(x, DVec3::Y, lookup, f).0[1];
            n += 1;
        }
    }
    sum / n as f64 / exact
}

/// `(mean ratio, t)` over the maps for `lookup`, photons built by `make`, the estimate scaled by
/// `scale` (1: the map's own).
fn check(lookup: &Lookup, make: impl Fn(u64) -> Vec<Photon>, scale: f64) -> (f64, f64) {
    let exact = ALBEDO / PI * (PHOTONS as f64 / 4.0) * POWER;
    let ratios: Vec<f64> = (0..MAPS)
        .map(|m| ratio(&PhotonMap::new(make(m)).expect("map"), lookup, exact) * scale)
        .collect();
    let mean = ratios.iter().sum::<f64>() / MAPS as f64;
    let var = ratios.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / (MAPS - 1) as f64;
    (mean, (mean - 1.0) / (var / MAPS as f64).sqrt())
}

#[test]
fn the_estimate_is_unbiased_on_a_uniformly_lit_plane() {
    let front = |m: u64| photons(100 + m, PHOTONS, DVec3::Y, POWER);
    // k nearest: r ≈ 0.02, the grid's disks are apart.
    let lookup = Lookup::new(60, 0.05);
    let (mean, t) = check(&lookup, front, 1.0);
    let k = lookup.k as f64;
    let (broken, t_broken) = check(&lookup, front, k / (k - 1.0));
    println!(
        "k = 60: mean ratio {mean:.5} (t = {t:+.2}); the k/(πr²) estimate {broken:.5} (t = {t_broken:+.2}); {} bytes per photon",
        PhotonMap::bytes_per_photon()
    );
    assert!(t.abs() < T_LIMIT, "biased: ratio {mean}, t = {t}");
    assert!(t_broken.abs() >= T_LIMIT, "the k/(πr²) bias goes unseen");
    // The maximum radius binding (≈ 15.7 photons expected within 0.01 < k = 60).
    let (mean, t) = check(&Lookup::new(60, 0.01), front, 1.0);
    println!("radius-limited: mean ratio {mean:.5} (t = {t:+.2})");
    assert!(
        t.abs() < T_LIMIT,
        "radius-limited estimate biased: {mean}, t = {t}"
    );
}

/// Photons on the back of a thin wall (same plane, opposite normal, ten times the power) are left
/// out by the normal filter without biasing the front's estimate: given the radius, the front
/// photons inside are still uniform, in proportion to their density.
#[test]
fn the_normal_filter_keeps_the_back_of_a_wall_out() {
    let both = |m: u64| {
        let mut v = photons(300 + m, PHOTONS, DVec3::Y, POWER);
        v.extend(photons(500 + m, PHOTONS, -DVec3::Y, 10.0 * POWER));
        v
    };
    let (mean, t) = check(&Lookup::new(60, 0.05), both, 1.0);
    println!("front and back: mean ratio {mean:.5} (t = {t:+.2})");
    assert!(t.abs() < T_LIMIT, "normal filter biased: {mean}, t = {t}");
}

/// Many photons at one position (repeated Metropolis paths land on one storage point): the tree
/// builds, and estimates stay finite (at the pile the radius is 0 and beside it every photon sits at
/// the kernel's edge: black there, never a NaN or an infinity).
#[test]
fn many_photons_at_one_position() {
    let mut v = photons(7, 1000, DVec3::Y, POWER);
    let at = DVec3::new(1.0, 0.0, 1.0);
    v.extend((0..5000).map(|_| Photon {
        p: at,
        wi: DVec3::Y,
        power: Rgb::splat(POWER),
        n: DVec3::Y,
    }));
    let map = PhotonMap::new(v).expect("map");
    let lookup = Lookup::new(60, 0.5);
    let f = |_: DVec3| Rgb::splat(ALBEDO / PI);
    let exactly = map.estimate(at, DVec3::Y, &lookup, f);
    // Beside the pile, its photons are the k nearest, all at the k-th distance: weight 0.
    let near = map.estimate(at + DVec3::X * 0.01, DVec3::Y, &lookup, f);
    let away = map.estimate(DVec3::new(0.3, 0.0, 0.3), DVec3::Y, &lookup, f);
    assert!(exactly.is_finite() && near.is_finite() && away.is_finite());
    assert_eq!(exactly, Rgb::BLACK);
    assert!(away.0[0] > 0.0);
    // Non-finite photons are refused.
    let bad = vec![Photon {
        p: DVec3::new(f64::NAN, 0.0, 0.0),
        wi: DVec3::Y,
        power: Rgb::splat(1.0),
        n: DVec3::Y,
    }];
    assert!(PhotonMap::new(bad).is_err());
}
