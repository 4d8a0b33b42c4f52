//! Standard photon mapping (Jensen 2001) approaches BDPT as the photon count grows: on the Cornell
//! box (glass and mirror spheres: caustics through the caustic map, indirect light through the
//! global map), the relative RMS difference of 6×6-pixel block means from the BDPT reference of
//! the convergence tests (128 samples per pixel over 16 batches) falls with every 16× more photons
//! (from 250 to 4 000 and from 1 000 to 16 000 light paths per map), and the image means agree to
//! 2% at the last count: 3.29%, 3.36%, 2.74%, 2.52%, image mean ratio 1.0145 at the last.
//!
//! The renders take 64 samples per pixel with the default (Sobol) sampler. PM's block means are
//! heavy-tailed (a final-gather ray that finds the light through the glass sphere lifts a block by
//! 15–37%), so a render's error says little at fewer samples: over 12 seeds, this test at the 16
//! samples per pixel and independent numbers it used to take would have failed for 8, with errors
//! of 3.9–16% (it passed at its one seed), and the error falls from each count to the next only
//! within that noise. With Sobol numbers at 64 samples per pixel, the errors over the same 12 seeds
//! are 2.7–3.4% at 250 paths and 1.2–2.5% at 16 000; every 16× step lowers them for all 12 (4× steps
//! not always: the maximum radii sit at the density rule's caps at these counts, `photon::radius`,
//! so the blur is the same and only the maps' noise falls); the image mean ratios are 1.006–1.017
//! (PM's blur: 1.012 ± 0.003). Fixed seeds: deterministic.

mod common;

use common::{H, MAX_EDGES, W, bdpt_batches, blocks};
use light_transport::Budget;
use light_transport::film::Image;
use light_transport::integrators::render;
use light_transport::photon::{PhotonMapper, PhotonMapping};
use light_transport::scene::{Scene, builtin};

fn rel_rms(a: &[f64], b: &[f64]) -> f64 {
    let num: f64 = a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum();
    let den: f64 = b.iter().map(|y| y * y).sum();
    (num / den).sqrt()
}

#[test]
fn photon_mapping_approaches_bdpt_as_photons_grow() {
    let scene = Scene::new(&builtin::builtin("cornell").unwrap(), Some((W, H))).unwrap();
    let batches = bdpt_batches(&scene);
    let reference: Vec<f64> = (0..batches[0].len())
        .map(|i| batches.iter().map(|b| b[i]).sum::<f64>() / batches.len() as f64)
        .collect();
    let mut errors = Vec::new();
    let mut last_ratio = 0.0;
    for paths in [250u64, 1_000, 4_000, 16_000] {
        let settings = PhotonMapping {
            global_paths: paths,
            caustic_paths: paths,
            ..PhotonMapping::new(MAX_EDGES)
        };
        let pm = PhotonMapper::new(&scene, settings).expect("photon maps");
        let film = render(&scene, &pm, Budget::SamplesPerPixel(64.0), 7, |_, _| true).0;
        let b = blocks(&Image::from_film(&film));
        let e = rel_rms(&b, &reference);
        let ratio = b.iter().sum::<f64>() / reference.iter().sum::<f64>();
        println!(
            "{paths} photon paths per map: relative RMS difference from BDPT {e:.4}, image mean ratio {ratio:.4}"
        );
        errors.push(e);
        last_ratio = ratio;
    }
    assert!(
        errors[2] < errors[0] && errors[3] < errors[1],
        "the error does not fall with 16× the photons: {errors:?}"
    );
    // No bias beyond the comparison's noise: the image means agree to 2%.
    assert!(
        (last_ratio - 1.0).abs() < 0.02,
        "image mean ratio {last_ratio}"
    );
}
