//! The `charted` command line end to end: the README's main job (`render` with no arguments),
//! every subcommand on a tiny image, and clear errors for bad input.

use std::path::{Path, PathBuf};
use std::process::Command;

fn charted() -> Command {
    Command::new(env!("CARGO_BIN_EXE_charted"))
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("charted-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn run(cmd: &mut Command) -> (bool, String, String) {
    let out = cmd.output().expect("the binary runs");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn render_with_no_arguments_writes_the_default_scene() {
    let d = tmp("default");
    let (ok, stdout, stderr) = run(charted().current_dir(&d));
    assert!(ok, "{stderr}");
    assert!(
        stdout.contains("rays") && stdout.contains("discarded  0"),
        "{stdout}"
    );
    for f in [
        "out/cornell-bdpt.exr",
        "out/cornell-bdpt.png",
        "out/cornell-bdpt.exr.samples",
    ] {
        assert!(d.join(f).exists(), "{f} missing");
    }
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn every_subcommand_runs_on_a_tiny_image() {
    let d = tmp("all");
    let o = |f: &str| d.join(f).to_string_lossy().into_owned();
    for algo in ["pt", "lt", "bdpt"] {
        let (ok, _, e) = run(charted().args([
            "render",
            "caustic",
            "--algo",
            algo,
            "--spp",
            "2",
            "--resolution",
            "24x16",
            "--quiet",
            "-o",
            &o(&format!("{algo}.exr")),
        ]));
        assert!(ok, "{algo}: {e}");
    }
    // The Metropolis family prints acceptance per move kind.
    for (algo, kind) in [
        ("pssmlt", "large_step"),
        ("mmlt", "small_step"),
        ("mlt", "multi-chain"),
        ("erpt", "caustic"),
        ("cmlt", "chart swap"),
    ] {
        let (ok, out, e) = run(charted().args([
            "render",
            "ring",
            "--algo",
            algo,
            "--spp",
            "2",
            "--resolution",
            "24x16",
            "--bootstrap",
            "2000",
            "--chains",
            "32",
            "--erpt-chain-length",
            "8",
            "--quiet",
            "-o",
            &o(&format!("{algo}.exr")),
        ]));
        assert!(ok && out.contains(kind), "{algo}: {out}{e}");
    }
    let (ok, out, e) = run(charted().args([
        "render",
        "door",
        "--algo",
        "cmlt",
        "--swaps",
        "replica",
        "--spp",
        "4",
        "--resolution",
        "24x16",
        "--bootstrap",
        "2000",
        "--chains",
        "64",
        "--quiet",
        "-o",
        &o("cmlt-replica.exr"),
    ]));
    assert!(ok && out.contains("replica exchange"), "{out}{e}");
    let (ok, _, e) = run(charted().args([
        "render",
        "caustic",
        "--spp",
        "2",
        "--resolution",
        "24x16",
        "--quiet",
        "--seed",
        "5",
        "-o",
        &o("b.exr"),
    ]));
    assert!(ok, "{e}");
    let (ok, out, e) =
        run(charted().args(["merge", &o("bdpt.exr"), &o("b.exr"), "-o", &o("merged.exr")]));
    assert!(ok && out.contains("4 samples per pixel"), "{out}{e}");
    let (ok, _, e) = run(charted().args([
        "reference",
        "caustic",
        "--spp",
        "4",
        "--resolution",
        "24x16",
        "-o",
        &o("ref.exr"),
    ]));
    assert!(ok, "{e}");
    let (ok, out, e) = run(charted().args([
        "compare",
        "caustic",
        "--algos",
        "pt,bdpt",
        "--time",
        "1s",
        "--checkpoints",
        "2",
        "--resolution",
        "24x16",
        "--reference",
        &o("ref.exr"),
        "-o",
        &o("cmp"),
    ]));
    assert!(ok, "{e}");
    assert!(out.contains("pt") && out.contains("bdpt"), "{out}");
    let csv = std::fs::read_to_string(d.join("cmp/errors.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 2 * 2, "{csv}");
    assert!(d.join("cmp/side_by_side.png").exists());
    let (ok, out, e) = run(charted().args(["info", "door"]));
    assert!(ok && out.contains("triangles"), "{out}{e}");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn bad_input_gives_clear_errors() {
    let d = tmp("bad");
    let bad = d.join("bad.pbrt");
    std::fs::write(
        &bad,
        "Camera \"perspective\" \"float fov\" [ 40 ]\nWorldBegin\nFrobnicate 3\nWorldEnd\n",
    )
    .unwrap();
    let cases: Vec<(Vec<String>, &str)> = vec![
        (
            vec!["render".into(), bad.to_string_lossy().into_owned()],
            "bad.pbrt:3",
        ),
        (vec!["render".into(), "no-such-scene".into()], "no scene"),
        (
            vec!["render".into(), "--resolution".into(), "100000x2".into()],
            "resolution",
        ),
        (vec!["render".into(), "--time=-3s".into()], "duration"),
        (
            vec!["render".into(), "--spp".into(), "0".into()],
            "at least 1",
        ),
        (
            vec![
                "render".into(),
                "--algo".into(),
                "mlt".into(),
                "--mutations".into(),
                "lens=0.5,teleport=0.5".into(),
            ],
            "unknown mutation 'teleport'",
        ),
        (
            vec![
                "render".into(),
                "--algo".into(),
                "mlt".into(),
                "--theta1".into(),
                "0.5".into(),
            ],
            "perturbation radii",
        ),
        (
            vec![
                "render".into(),
                "--algo".into(),
                "cmlt".into(),
                "--ipsm".into(),
                "NaN".into(),
            ],
            "ipsm",
        ),
        (
            vec![
                "render".into(),
                "--algo".into(),
                "cmlt".into(),
                "--swaps".into(),
                "tempering".into(),
            ],
            "tempering",
        ),
        (
            vec![
                "compare".into(),
                "cornell".into(),
                "--reference".into(),
                "/nonexistent.exr".into(),
                "--time".into(),
                "1s".into(),
            ],
            "nonexistent",
        ),
    ];
    for (args, needle) in cases {
        let (ok, out, err) = run(charted().args(&args).current_dir(&d));
        assert!(!ok, "{args:?} succeeded: {out}");
        assert!(
            err.contains(needle),
            "{args:?}: expected {needle:?} in {err:?}"
        );
        assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
    }
    let _ = std::fs::remove_dir_all(Path::new(&d));
}
