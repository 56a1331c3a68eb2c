//! Frame sequences of three-dimensional motion: each frame's strokes (body segments in space)
//! projected orthographically onto a plane and written as one SVG per frame, all frames on the
//! same scale so the motion can be watched (in a browser, or joined into a video by any tool).

use std::fmt::Write as _;

/// A segment of a body in space (from `from` to `to`), or a fixed point when they coincide.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stroke {
    /// One end, space coordinates.
    pub from: [f64; 3],
    /// The other end.
    pub to: [f64; 3],
    /// The body it belongs to (its colour); `None` for the fixed frame (drawn grey).
    pub body: Option<usize>,
}

/// One frame: its time and strokes.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// Time.
    pub t: f64,
    /// What to draw.
    pub strokes: Vec<Stroke>,
}

/// The plane a frame is projected on (orthographic, `z` up where it is shown).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum View {
    /// Looking along `−y`: right `x`, up `z`.
    #[default]
    Xz,
    /// Looking along `x`: right `y`, up `z`.
    Yz,
    /// From above: right `x`, up `y`.
    Xy,
    /// Isometric: the axes at 120° on the page, `z` up.
    Iso,
}

impl View {
    /// The point `p` on the page (right, up), in space units.
    #[must_use]
    pub fn project(self, p: [f64; 3]) -> [f64; 2] {
        let [x, y, z] = p;
        match self {
            Self::Xz => [x, z],
            Self::Yz => [y, z],
            Self::Xy => [x, y],
            Self::Iso => {
                let c = 3f64.sqrt() / 2.0;
                [c * (x - y), z - 0.5 * (x + y)]
            }
        }
    }
}

/// Colours of bodies, cycled.
const COLOURS: [&str; 6] = [
    "#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#17becf",
];

/// One SVG per frame, `size` pixels square, every frame with the same scale and origin: the
/// bounding box of all frames' projected strokes, padded by 5 % and centred with equal scales
/// on both page axes.
#[must_use]
pub fn svg_frames(frames: &[Frame], view: View, size: u32) -> Vec<String> {
    let points = frames
        .iter()
        .flat_map(|f| &f.strokes)
        .flat_map(|s| [view.project(s.from), view.project(s.to)]);
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in points.filter(|p| p.iter().all(|c| c.is_finite())) {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    if lo[0] > hi[0] {
        (lo, hi) = ([-1.0; 2], [1.0; 2]);
    }
    let span = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1e-9) * 1.1;
    let centre = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])];
    let px = f64::from(size);
    let scale = px / span;
    let page = |p: [f64; 3]| {
        let [u, v] = view.project(p);
        (
            0.5 * px + (u - centre[0]) * scale,
            0.5 * px - (v - centre[1]) * scale,
        )
    };
    frames
        .iter()
        .map(|frame| {
            let mut svg = format!(
                "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{size}\" height=\"{size}\" viewBox=\"0 0 {size} {size}\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
            );
            for s in &frame.strokes {
                let colour = s.body.map_or("#808080", |b| COLOURS[b % COLOURS.len()]);
                let ((x1, y1), (x2, y2)) = (page(s.from), page(s.to));
                if s.from == s.to {
                    let _ = writeln!(
                        svg,
                        "<circle cx=\"{x1:.2}\" cy=\"{y1:.2}\" r=\"4\" fill=\"{colour}\"/>"
                    );
                } else {
                    let _ = writeln!(
                        svg,
                        "<line x1=\"{x1:.2}\" y1=\"{y1:.2}\" x2=\"{x2:.2}\" y2=\"{y2:.2}\" stroke=\"{colour}\" stroke-width=\"3\" stroke-linecap=\"round\"/>"
                    );
                }
            }
            let _ = writeln!(
                svg,
                "<text x=\"8\" y=\"20\" font-family=\"sans-serif\" font-size=\"14\">t = {:.4}</text>\n</svg>",
                frame.t
            );
            svg
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The isometric view maps the unit axes to unit-free directions 120° apart (x right-down,
    /// y left-down, z up), each of the same length √(3/4 + 1/4) = 1.
    #[test]
    fn isometric_axes_are_120_degrees_apart() {
        let axes =
            [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]].map(|e| View::Iso.project(e));
        for (i, a) in axes.iter().enumerate() {
            assert!((a[0].hypot(a[1]) - 1.0).abs() < 1e-15);
            let b = axes[(i + 1) % 3];
            assert!(
                (a[0] * b[0] + a[1] * b[1] + 0.5).abs() < 1e-15,
                "{a:?} {b:?}"
            );
        }
    }

    /// Two frames of one stroke turning from horizontal to vertical about the origin (side
    /// 1): the common box is 1 × 1 (padded to 1.1), so on a 110-pixel page the scale is 100
    /// pixels per unit and the box's centre (0.5, −0.5) sits at the page's centre (55, 55).
    /// A per-frame box would put frame 0's stroke at y = 55 (its own box is flat) and fail.
    #[test]
    fn frames_share_one_scale() {
        let stroke = |to| Stroke {
            from: [0.0; 3],
            to,
            body: Some(0),
        };
        let frames = [
            Frame {
                t: 0.0,
                strokes: vec![stroke([1.0, 0.0, 0.0])],
            },
            Frame {
                t: 1.0,
                strokes: vec![stroke([0.0, 0.0, -1.0])],
            },
        ];
        let svg = svg_frames(&frames, View::Xz, 110);
        assert!(
            svg[0].contains("<line x1=\"5.00\" y1=\"5.00\" x2=\"105.00\" y2=\"5.00\""),
            "{}",
            svg[0]
        );
        assert!(
            svg[1].contains("<line x1=\"5.00\" y1=\"5.00\" x2=\"5.00\" y2=\"105.00\""),
            "{}",
            svg[1]
        );
        assert!(svg[1].contains("t = 1.0000"));
    }
}
