//! `dirac animate`: the motion of a scene's rigid bodies as a sequence of projected SVG frames.
//!
//! Each body is drawn as segments from its centre of mass to the points it is attached at (its
//! joint origins and named points), or as its three body axes when it has none; the fixed ends of
//! joints to the ground are grey dots.

use std::path::PathBuf;

use dirac_graph::SubsystemId;
use dirac_output::animate::{Frame, Stroke, View, svg_frames};
use dirac_rigid::{COORDINATES, RigidBody, so3};
use dirac_scene::{PartKind, Scene};
use dirac_sim::{Probe, Signal};

use crate::Failure;

/// Arguments of `dirac animate`.
#[derive(Debug, clap::Args)]
pub(crate) struct AnimateArgs {
    /// Scene file (.toml) with rigid bodies.
    file: PathBuf,
    /// Directory to write `frame_00000.svg`, … into (created if missing).
    #[arg(long)]
    frames: PathBuf,
    /// Number of frames, evenly spaced from t = 0 to the end.
    #[arg(long, default_value_t = 100)]
    count: usize,
    /// Projection plane.
    #[arg(long, value_enum, default_value = "xz")]
    view: ViewArg,
    /// End time (default: the scene's t_end); SPICE suffixes read.
    #[arg(long, value_parser = crate::spice_number)]
    t_end: Option<f64>,
    /// Frame size in pixels.
    #[arg(long, default_value_t = 480)]
    size: u32,
}

/// The projection plane.
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub(crate) enum ViewArg {
    /// Right x, up z.
    Xz,
    /// Right y, up z.
    Yz,
    /// Right x, up y (from above).
    Xy,
    /// Isometric, z up.
    Iso,
}

/// A body to draw: its part, and the body-fixed points drawn from its centre of mass.
struct Drawn {
    part: SubsystemId,
    attachments: Vec<[f64; 3]>,
    /// Length of the body axes drawn when there are no attachments.
    axes: f64,
}

/// Runs the scene and writes the frames.
pub(crate) fn animate(args: &AnimateArgs) -> Result<(), Failure> {
    if args.count == 0 || args.size == 0 {
        return Err(Failure::Input("--count and --size must be positive".into()));
    }
    let scene = Scene::from_file(&args.file).map_err(|e| Failure::Input(e.to_string()))?;
    let built = scene.build().map_err(|e| Failure::Input(e.to_string()))?;
    let mut bodies = Vec::new();
    for part in &scene.parts {
        let PartKind::RigidBody(p) = &part.kind else {
            continue;
        };
        let Some(id) = built.graph.subsystem_id(&part.name) else {
            continue;
        };
        let mut attachments: Vec<[f64; 3]> = p.points.values().copied().collect();
        for (_, joint) in &built.rigid_joints {
            for side in [&joint.a, &joint.b] {
                if side.body.as_deref() == Some(part.name.as_str()) {
                    attachments.push(side.frame.origin);
                }
            }
        }
        attachments.retain(|r| so3::dot(r, r) > 0.0);
        let reach = attachments
            .iter()
            .map(|r| so3::dot(r, r).sqrt())
            .fold(0.0, f64::max);
        bodies.push(Drawn {
            part: id,
            attachments,
            axes: if reach > 0.0 { reach } else { 0.1 },
        });
    }
    if bodies.is_empty() {
        return Err(Failure::Input(format!(
            "{}: the scene has no rigid bodies to animate",
            args.file.display()
        )));
    }
    let anchors: Vec<[f64; 3]> = built
        .rigid_joints
        .iter()
        .flat_map(|(_, j)| [&j.a, &j.b])
        .filter(|s| s.body.is_none())
        .map(|s| s.frame.origin)
        .collect();
    let signals: Vec<Signal> = bodies
        .iter()
        .flat_map(|b| {
            (0..COORDINATES.len()).map(move |c| {
                Signal::new(
                    format!("{}", c),
                    Probe::Position {
                        part: b.part,
                        coordinate: c,
                    },
                )
            })
        })
        .collect();
    let t_end = args.t_end.unwrap_or(built.t_end);
    let mut sim = built.simulation()?;
    let (run, _) = sim.run(t_end, &signals)?;
    let rows = run.len();
    let picks: Vec<usize> = if args.count == 1 || rows == 1 {
        vec![0]
    } else {
        (0..args.count)
            .map(|i| (i * (rows - 1) + (args.count - 1) / 2) / (args.count - 1))
            .collect()
    };
    let frames: Vec<Frame> = picks
        .iter()
        .map(|&k| {
            let row = run.row(k);
            let mut strokes: Vec<Stroke> = anchors
                .iter()
                .map(|&a| Stroke {
                    from: a,
                    to: a,
                    body: None,
                })
                .collect();
            for (i, b) in bodies.iter().enumerate() {
                let q = &row[i * COORDINATES.len()..(i + 1) * COORDINATES.len()];
                let (x, r) = (RigidBody::position(q), RigidBody::rotation(q));
                let at = |v: [f64; 3]| {
                    let w = so3::apply(&r, &v);
                    [x[0] + w[0], x[1] + w[1], x[2] + w[2]]
                };
                if b.attachments.is_empty() {
                    for k in 0..3 {
                        let mut e = [0.0; 3];
                        e[k] = b.axes;
                        strokes.push(Stroke {
                            from: x,
                            to: at(e),
                            body: Some(i),
                        });
                    }
                }
                for &p in &b.attachments {
                    strokes.push(Stroke {
                        from: x,
                        to: at(p),
                        body: Some(i),
                    });
                }
            }
            Frame {
                t: run.t()[k],
                strokes,
            }
        })
        .collect();
    let view = match args.view {
        ViewArg::Xz => View::Xz,
        ViewArg::Yz => View::Yz,
        ViewArg::Xy => View::Xy,
        ViewArg::Iso => View::Iso,
    };
    let dir = &args.frames;
    std::fs::create_dir_all(dir).map_err(|e| Failure::Input(format!("{}: {e}", dir.display())))?;
    let svgs = svg_frames(&frames, view, args.size);
    for (i, svg) in svgs.iter().enumerate() {
        let path = dir.join(format!("frame_{i:05}.svg"));
        std::fs::write(&path, svg)
            .map_err(|e| Failure::Input(format!("{}: {e}", path.display())))?;
    }
    eprintln!(
        "wrote {} frames (t = 0 … {}) of {} bodies to {}",
        svgs.len(),
        run.t()[rows - 1],
        bodies.len(),
        dir.display()
    );
    Ok(())
}
