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

/// `charted render cornell --algo ALGO --spp 1 --resolution RES EXTRA… -o OUT`.
fn render_cornell(algo: &str, res: &str, extra: &[&str], out: &str) -> (bool, String, String) {
    let args = [
        "render",
        "cornell",
        "--algo",
        algo,
        "--spp",
        "1",
        "--resolution",
        res,
    ];
    run(charted().args(args).args(extra).args(["-o", out]))
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
        ("erpt", "lens"),
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
    // Density estimation in CMLT: the merge statistics and the bias warning are printed.
    let (ok, out, e) = run(charted().args([
        "render",
        "cornell",
        "--algo",
        "cmlt",
        "--density-estimation",
        "0.3",
        "--merge-light-paths",
        "2000",
        "--spp",
        "4",
        "--resolution",
        "24x16",
        "--bootstrap",
        "2000",
        "--chains",
        "64",
        "-o",
        &o("cmlt-de.exr"),
    ]));
    assert!(
        ok && out.contains("density estimation: merge") && out.contains("slightly biased"),
        "{out}{e}"
    );
    // Photon mapping reports its maps; a bad setting is a clear error.
    let (ok, out, e) = run(charted().args([
        "render",
        "cornell",
        "--algo",
        "pm",
        "--spp",
        "1",
        "--resolution",
        "24x16",
        "--global-photons",
        "2000",
        "--caustic-photons",
        "2000",
        "-o",
        &o("pm.exr"),
    ]));
    assert!(
        ok && out.contains("bytes per photon") && out.contains("d_max global"),
        "{out}{e}"
    );
    let (ok, _, e) = run(charted().args([
        "render",
        "cornell",
        "--algo",
        "pm",
        "--spp",
        "1",
        "--resolution",
        "8x8",
        "--photon-k",
        "1",
        "-o",
        &o("pm-bad.exr"),
    ]));
    assert!(!ok && e.contains("k ≥ 2"), "{e}");
    for (flag, value) in [("--radius-alpha", "0"), ("--global-radius", "NaN")] {
        let (ok, _, e) = render_cornell("pm", "8x8", &[flag, value], &o("pm-bad.exr"));
        assert!(!ok && e.contains("(0, 1]"), "{flag} {value}: {e}");
    }
    // Russian roulette in the walks of BDPT and PSSMLT is reported, in both walks or light walks
    // only; by default light walks stop from the first surface vertex; --roulette 0 turns it
    // off, and --roulette-walks with it is an error.
    for algo in ["bdpt", "pssmlt"] {
        let (ok, out, e) = render_cornell(algo, "24x16", &[], &o("walks.exr"));
        let default = "roulette   light subpaths may stop from vertex 1 on";
        assert!(ok && out.contains(default), "{algo} default: {out}{e}");
        let (ok, out, e) = render_cornell(algo, "24x16", &["--roulette", "0"], &o("walks.exr"));
        assert!(ok && !out.contains("roulette  "), "{algo} off: {out}{e}");
        let lines = [
            ("both", "camera and light subpaths"),
            ("light", "roulette   light"),
        ];
        for (walks, line) in lines {
            let extra = ["--roulette", "1", "--roulette-walks", walks];
            let (ok, out, e) = render_cornell(algo, "24x16", &extra, &o("walks.exr"));
            assert!(ok && out.contains(line), "{algo} {walks}: {out}{e}");
        }
        let extra = ["--roulette", "0", "--roulette-walks", "light"];
        let (ok, _, e) = render_cornell(algo, "8x8", &extra, &o("walks-bad.exr"));
        assert!(!ok && e.contains("needs --roulette"), "{algo}: {e}");
    }
    // Path tracing's roulette is off unless --roulette N ≥ 1 asks for it; it is reported, and
    // --roulette-walks (BDPT and PSSMLT only) is an error.
    let (ok, out, e) = render_cornell("pt", "24x16", &[], &o("pt-walks.exr"));
    assert!(ok && !out.contains("roulette  "), "pt default: {out}{e}");
    let (ok, out, e) = render_cornell("pt", "24x16", &["--roulette", "3"], &o("pt-walks.exr"));
    let line = "roulette   paths may stop from vertex 3 on";
    assert!(ok && out.contains(line), "pt --roulette 3: {out}{e}");
    let extra = ["--roulette", "1", "--roulette-walks", "both"];
    let (ok, _, e) = render_cornell("pt", "8x8", &extra, &o("pt-walks-bad.exr"));
    assert!(
        !ok && e.contains("camera walks only"),
        "pt --roulette-walks: {e}"
    );
    // Russian roulette on shadow rays (PT and BDPT) is reported; a bad fraction is an error.
    for algo in ["pt", "bdpt"] {
        let flag = "--shadow-roulette";
        let (ok, out, e) = render_cornell(algo, "24x16", &[flag, "0.05"], &o("shadow.exr"));
        assert!(ok && out.contains("roulette on shadow rays"), "{out}{e}");
        let (ok, _, e) = render_cornell(algo, "8x8", &[flag, "NaN"], &o("shadow-bad.exr"));
        assert!(!ok && e.contains("shadow-roulette"), "{e}");
    }
    // Metropolis photon sampling with the shipped user paths of `box`; a bad user-path file is an
    // error naming its line.
    let (ok, out, e) = run(charted().args([
        "render",
        "box",
        "--algo",
        "mps",
        "--spp",
        "1",
        "--resolution",
        "24x24",
        "--photon-mutations",
        "8",
        "--chains",
        "16",
        "--bootstrap",
        "500",
        "--user-paths",
        concat!(env!("CARGO_MANIFEST_DIR"), "/examples/box.user-paths"),
        "-o",
        &o("mps.exr"),
    ]));
    assert!(
        ok && out.contains("t_B") && out.contains("user-path") && out.contains("bytes per photon"),
        "{out}{e}"
    );
    let bad = o("bad.user-paths");
    std::fs::write(&bad, "path\n0 1.98 0\n0.5 0 0.5 400\n").expect("write");
    let (ok, _, e) = run(charted().args([
        "render",
        "box",
        "--algo",
        "mps",
        "--spp",
        "1",
        "--resolution",
        "8x8",
        "--user-paths",
        &bad,
        "-o",
        &o("mps-bad.exr"),
    ]));
    assert!(!ok && e.contains("bad.user-paths:3:"), "{e}");
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
                "render".into(),
                "--algo".into(),
                "cmlt".into(),
                "--density-estimation".into(),
                "0.3".into(),
                "--merge-radius".into(),
                "0".into(),
            ],
            "merge radius",
        ),
        (
            vec![
                "render".into(),
                "--algo".into(),
                "cmlt".into(),
                "--density-estimation".into(),
                "0.8".into(),
                "--ipsm".into(),
                "0.4".into(),
            ],
            "sum to",
        ),
        (
            vec![
                "render".into(),
                "--algo".into(),
                "mmlt".into(),
                "--sampler".into(),
                "independent".into(),
            ],
            "--sampler applies to the algorithms that render in passes",
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

/// Send `signal` (a `kill` name) to a process.
fn signal(pid: u32, name: &str) {
    let ok = Command::new("kill")
        .args([&format!("-{name}"), &pid.to_string()])
        .status()
        .expect("kill runs")
        .success();
    assert!(ok, "kill -{name} {pid} failed");
}

/// The first SIGINT (or SIGTERM) stops a long render at the end of its pass or round: it writes
/// the EXR, PNG and sidecar with the samples actually taken, prints its summary and exits with
/// status 130, well before its time budget.
#[test]
fn an_interrupt_keeps_the_work() {
    let d = tmp("interrupt");
    for (algo, sig) in [("bdpt", "INT"), ("mlt", "TERM")] {
        let exr = d.join(format!("{algo}.exr"));
        let start = std::time::Instant::now();
        let child = charted()
            .args([
                "render",
                "door",
                "--algo",
                algo,
                "--time",
                "120s",
                "--resolution",
                "64x48",
                "--bootstrap",
                "4000",
                "--chains",
                "64",
                "--quiet",
                "-o",
            ])
            .arg(&exr)
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .expect("the binary runs");
        std::thread::sleep(std::time::Duration::from_secs(3));
        signal(child.id(), sig);
        let out = child.wait_with_output().expect("the render ends");
        let secs = start.elapsed().as_secs_f64();
        let (stdout, stderr) = (
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr),
        );
        assert_eq!(out.status.code(), Some(130), "{algo}: {stdout}{stderr}");
        assert!(secs < 60.0, "{algo}: took {secs:.1} s after the signal");
        assert!(stdout.contains("(interrupted)"), "{algo}: {stdout}");
        assert!(exr.exists() && exr.with_extension("png").exists());
        let sidecar = std::fs::read_to_string(format!("{}.samples", exr.display())).unwrap();
        let samples: f64 = sidecar
            .lines()
            .find_map(|l| l.strip_prefix("samples="))
            .and_then(|v| v.parse().ok())
            .unwrap();
        assert!(samples > 0.0, "{algo}: {sidecar}");
        println!(
            "{algo}: SIG{sig} after 3 s, exited after {secs:.1} s with {samples} samples per pixel"
        );
    }
    let _ = std::fs::remove_dir_all(&d);
}

/// A second signal quits at once, without waiting for the pass to end: on a 1024×768 image a
/// BDPT pass takes several seconds, and the process is gone well before, having written nothing.
#[test]
fn a_second_interrupt_quits_at_once() {
    let d = tmp("interrupt2");
    let exr = d.join("b.exr");
    let start = std::time::Instant::now();
    let child = charted()
        .args([
            "render",
            "door",
            "--time",
            "120s",
            "--resolution",
            "1024x768",
            "--quiet",
            "-o",
        ])
        .arg(&exr)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("the binary runs");
    std::thread::sleep(std::time::Duration::from_millis(1500));
    signal(child.id(), "INT");
    std::thread::sleep(std::time::Duration::from_millis(100));
    signal(child.id(), "INT");
    let out = child.wait_with_output().expect("the render ends");
    let secs = start.elapsed().as_secs_f64();
    assert_eq!(out.status.code(), Some(130));
    assert!(secs < 3.0, "took {secs:.1} s");
    assert!(!exr.exists(), "the first pass was finished and written");
    let _ = std::fs::remove_dir_all(&d);
}

/// `--compact-bvh` builds another BVH over the same geometry (cornell's quads share
/// references): the image is the same, byte for byte.
#[test]
fn compact_bvh_renders_the_same_image() {
    let d = tmp("compact");
    let o = |f: &str| d.join(f).to_string_lossy().into_owned();
    for (extra, out) in [
        (&[][..], "plain.exr"),
        (&["--compact-bvh"][..], "compact.exr"),
    ] {
        let (ok, _, e) = render_cornell("bdpt", "24x16", extra, &o(out));
        assert!(ok, "{e}");
    }
    let read = |f: &str| std::fs::read(o(f)).expect("written");
    assert_eq!(read("plain.exr"), read("compact.exr"));
    // And the compact BVH is really another one: `info` counts fewer references.
    let references = |extra: &[&str]| {
        let (ok, out, e) = run(charted().args(["info", "cornell"]).args(extra));
        assert!(ok, "{e}");
        let line = out
            .lines()
            .find(|l| l.starts_with("bvh"))
            .expect("a bvh line");
        let n: usize = line
            .split_whitespace()
            .nth(1)
            .and_then(|n| n.parse().ok())
            .expect(line);
        n
    };
    assert!(references(&["--compact-bvh"]) < references(&[]));
    let _ = std::fs::remove_dir_all(&d);
}

/// `--sampler` reaches the pass-based estimators: the report names it, the two samplers render
/// different images from one seed, and Sobol is the default.
#[test]
fn the_sampler_option_reaches_the_passes() {
    let d = tmp("sampler");
    let o = |f: &str| d.join(f).to_string_lossy().into_owned();
    let mut images = Vec::new();
    for (extra, name) in [
        (&[][..], "sobol"),
        (&["--sampler", "sobol"][..], "sobol"),
        (&["--sampler", "independent"][..], "independent"),
    ] {
        let out = o(&format!("{}-{name}.exr", images.len()));
        let (ok, stdout, e) = render_cornell("bdpt", "16x12", extra, &out);
        assert!(ok, "{extra:?}: {e}");
        assert!(stdout.contains(&format!("sampler    {name}")), "{stdout}");
        images.push(std::fs::read(&out).unwrap());
    }
    assert_eq!(images[0], images[1], "Sobol is the default");
    assert_ne!(images[1], images[2], "the samplers draw different numbers");
    let _ = std::fs::remove_dir_all(&d);
}
