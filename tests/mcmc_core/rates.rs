//! Measured false-positive and detection rates of the statistical checks (ignored in CI: about a
//! minute in release). Run with
//! `cargo test --release --test mcmc_core -- --ignored --nocapture rates`.
//!
//! False positives: every correct kernel of `broken::cases()` over 200 seeds at α = 0.01 (so the
//! expected rate per check is ≤ 1%, and any failure of any check on a correct kernel counts).
//! Detection: every broken kernel over 50 seeds at the CI level α = 1e-4.

use crate::broken::cases;

#[test]
#[ignore = "long: measures rates over many seeds"]
fn measured_rates() {
    println!(
        "{:<48} {:>7} {:>10} {:>10} {:>10} {:>10}",
        "kernel", "seeds", "pointwise", "exchange", "invariance", "any check"
    );
    for case in cases() {
        let (seeds, alpha) = if case.broken {
            (50u64, 1e-4)
        } else {
            (200u64, 1e-2)
        };
        let mut fails = [0u32; 4];
        let mut applicable = [0u32; 3];
        for s in 0..seeds {
            let v = (case.run)(1000 + s, alpha);
            for (i, r) in [v.pointwise, v.exchangeability, v.invariance]
                .iter()
                .enumerate()
            {
                if let Some(passed) = r {
                    applicable[i] += 1;
                    fails[i] += !passed as u32;
                }
            }
            fails[3] += v.caught() as u32;
        }
        let pct = |f: u32, n: u32| {
            if n == 0 {
                "—".to_string()
            } else {
                format!("{:.1}%", 100.0 * f as f64 / n as f64)
            }
        };
        println!(
            "{:<48} {:>7} {:>10} {:>10} {:>10} {:>10}",
            format!("{}{}", if case.broken { "BROKEN " } else { "" }, case.name),
            seeds,
            pct(fails[0], applicable[0]),
            pct(fails[1], applicable[1]),
            pct(fails[2], applicable[2]),
            pct(fails[3], seeds as u32)
        );
    }
}
