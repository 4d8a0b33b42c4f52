//! The user-path file (`--user-paths FILE`, `pathspace::user_path`): the shipped example for the
//! built-in `box` loads with the specular bounces its paths take, and every kind of bad input is
//! an error naming the file and the line.

use light_transport::pathspace::UserPaths;
use light_transport::scene::{Scene, builtin};
use std::path::Path;

fn scene() -> Scene {
    Scene::new(&builtin::builtin("box").expect("box"), Some((32, 32))).expect("scene")
}

#[test]
fn the_shipped_box_paths_load() {
    let scene = scene();
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/box.user-paths");
    let paths = UserPaths::load(&file, &scene).expect("the shipped user paths load");
    assert_eq!(paths.len(), 10);
    // Five straight through the glass ball (two refractions), five by the mirror wall first.
    let through: Vec<&_> = paths.paths.iter().filter(|p| p.points.len() == 4).collect();
    let mirrored: Vec<&_> = paths.paths.iter().filter(|p| p.points.len() == 5).collect();
    assert_eq!((through.len(), mirrored.len()), (5, 5));
    for p in through {
        assert_eq!(p.specular, vec![false, true, true, false]);
        assert_eq!(p.refracts[1..3], [true, true]);
        assert!((p.beta[0].to_degrees() - 5.0).abs() < 1e-12);
    }
    for p in mirrored {
        assert_eq!(p.specular, vec![false, true, true, true, false]);
        assert_eq!(p.refracts[1..4], [false, true, true]);
        assert!((p.beta[0].to_degrees() - 1.0).abs() < 1e-12);
        assert!((p.beta[1].to_degrees() - 5.0).abs() < 1e-12);
    }
}

/// Each bad file gives an error `name:line: reason` at the line of the fault.
#[test]
fn bad_files_are_errors_with_file_and_line() {
    let scene = scene();
    let light = "-0.005 1.979 -0.03";
    let floor = "-0.5 0 0.5";
    let cases: Vec<(String, usize, &str)> = vec![
        (format!("{light}\n"), 1, "before the first 'path'"),
        (
            format!("path\n{light}\n-0.5 zero 0.5\n"),
            3,
            "not a finite number",
        ),
        (format!("path\n{light}\n-0.5 0 0.5 3 4\n"), 3, "fields"),
        (format!("path\n{light}\n{floor} 120\n"), 3, "(0°, 90°]"),
        (format!("path beta=-2\n{light}\n{floor}\n"), 1, "(0°, 90°]"),
        (
            format!("path colour=red\n{light}\n{floor}\n"),
            1,
            "unknown path option",
        ),
        (
            format!("# one point\npath\n{light}\n"),
            2,
            "at least 2 points",
        ),
        // The first point is on the back wall, not on a light.
        (
            "path\n-0.7 1.5 -1\n-0.8 0 0.8\n".into(),
            2,
            "must lie on a light",
        ),
        // Not on a surface: the segment reaches the floor before this point (in mid-air).
        (format!("\npath\n{light}\n-0.5 0.5 0.5\n"), 4, "blocked"),
        // The last point on the glass ball (specular only).
        (
            format!("path\n{light}\n0.3 0.7 0.25\n"),
            3,
            "scatters diffusely",
        ),
        (String::new(), 1, "no 'path'"),
    ];
    for (text, line, reason) in cases {
        let e = UserPaths::parse(&text, "paths.txt", &scene)
            .expect_err(&format!("accepted a bad file:\n{text}"))
            .to_string();
        println!("{e}");
        assert!(
            e.starts_with(&format!("paths.txt:{line}: ")),
            "{e:?}: expected line {line}"
        );
        assert!(e.contains(reason), "{e:?}: expected {reason:?}");
    }
    let missing =
        UserPaths::load(Path::new("/nonexistent/paths.txt"), &scene).expect_err("no file");
    assert!(missing.to_string().starts_with("/nonexistent/paths.txt: "));
}
