//! `dirac animate`: the frames of a rigid-body scene show the mechanism as it is. In every frame
//! of DART's pendulum chain each link's drawn segment ends where the next link's begins (the
//! revolute joints hold the links together), the first starts at the ground anchor, and the
//! chain moves between frames; scenes without rigid bodies are refused with exit code 2.

mod common;

use common::scratch;
use std::path::PathBuf;
use std::process::Command;

fn dirac() -> Command {
    Command::new(env!("CARGO_BIN_EXE_dirac"))
}

fn scene(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples/scenes")
        .join(name)
}

/// The numbers in `attr="…"` of every element starting with `tag` in `svg`.
fn attributes(svg: &str, tag: &str, names: &[&str]) -> Vec<Vec<f64>> {
    svg.lines()
        .filter(|l| l.starts_with(tag))
        .map(|l| {
            names
                .iter()
                .map(|n| {
                    let key = format!(" {n}=\"");
                    let start = l.find(&key).expect("attribute") + key.len();
                    let end = start + l[start..].find('"').expect("closing quote");
                    l[start..end].parse().expect("number")
                })
                .collect()
        })
        .collect()
}

/// Pixels: the SVG prints two decimals.
const PIXEL: f64 = 0.01;

/// Mutation seen to fail: drawing attachment points at `x + r` (without the rotation) breaks
/// the chain in frame 0 ("gap 20.65 between links").
#[test]
fn chain_frames_show_a_connected_moving_chain() {
    let dir = scratch("chain_frames");
    let _ = std::fs::remove_dir_all(&dir);
    let out = dirac()
        .args(["animate", "--count", "3", "--t-end", "0.5", "--frames"])
        .arg(&dir)
        .arg(scene("pendulum_chain.toml"))
        .output()
        .expect("runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut first_tips = Vec::new();
    for i in 0..3 {
        let svg = std::fs::read_to_string(dir.join(format!("frame_{i:05}.svg"))).expect("frame");
        let lines = attributes(&svg, "<line", &["x1", "y1", "x2", "y2"]);
        let anchors = attributes(&svg, "<circle", &["cx", "cy"]);
        assert_eq!((lines.len(), anchors.len()), (10, 1), "{svg}");
        assert!((lines[0][0] - anchors[0][0]).abs() <= PIXEL);
        assert!((lines[0][1] - anchors[0][1]).abs() <= PIXEL);
        for pair in lines.windows(2) {
            let gap = (pair[0][2] - pair[1][0]).hypot(pair[0][3] - pair[1][1]);
            assert!(gap <= PIXEL, "frame {i}: gap {gap} between links");
        }
        first_tips.push((lines[9][2], lines[9][3]));
    }
    let moved = (first_tips[0].0 - first_tips[2].0).hypot(first_tips[0].1 - first_tips[2].1);
    assert!(moved > 10.0, "the chain's end moved {moved} pixels");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn scenes_without_rigid_bodies_are_refused() {
    let dir = scratch("no_frames");
    let out = dirac()
        .args(["animate", "--frames"])
        .arg(&dir)
        .arg(scene("dc_motor.toml"))
        .output()
        .expect("runs");
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no rigid bodies"));
}
