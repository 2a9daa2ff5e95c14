//! The body's picture: the `/body` scene drawn as an SVG
//! ([`Scene::body_svg`]).

use anguilla_ipc::StateSnapshot;
use nalgebra::Vector3;

use crate::scene::{Link, Scene};

impl Scene {
    /// The `/body` scene of `s` drawn as an SVG: seen from above and from
    /// the side, each link an ellipse (its ellipsoid's outline), the head
    /// on the right. The README's picture comes from here.
    ///
    /// Both views share one scale, chosen so that the whole body fits the
    /// picture's width and each view at most 220 pixels of
    /// height, however the body is bent; each view's label has a strip of
    /// its own above the drawing, so no link covers it.
    pub fn body_svg(&self, s: &StateSnapshot) -> String {
        use core::fmt::Write as _;
        let links = self.links(s);
        let views = [
            ("from above (head on the right)", Self::outlines(&links, 0)),
            ("from the side", Self::outlines(&links, 1)),
        ];
        // The extents in metres: one horizontal range for both views, so the
        // head is at the same x in both; a vertical one per view.
        let mut u = (f64::INFINITY, f64::NEG_INFINITY);
        let mut v = [(f64::INFINITY, f64::NEG_INFINITY); 2];
        for (k, (_, outlines)) in views.iter().enumerate() {
            for e in outlines {
                let (hu, hv) = e.half_extents();
                u = (u.0.min(e.u - hu), u.1.max(e.u + hu));
                v[k] = (v[k].0.min(e.v - hv), v[k].1.max(e.v + hv));
            }
        }
        // A body of no links still gets a (blank) picture.
        let span = |r: (f64, f64)| if r.1 > r.0 { r.1 - r.0 } else { 0.0 };
        let width = SVG_WIDTH - 2.0 * SVG_MARGIN;
        let scale = v
            .iter()
            .map(|&r| SVG_VIEW_MAX / span(r).max(1e-9))
            .fold(width / span(u).max(1e-9), f64::min);
        let x0 = SVG_MARGIN + (width - span(u) * scale) / 2.0;
        let mut o = String::new();
        let mut body = String::new();
        let mut top = SVG_MARGIN;
        for (k, (label, outlines)) in views.iter().enumerate() {
            let _ = writeln!(
                body,
                "<text x=\"{SVG_MARGIN}\" y=\"{:.1}\" fill=\"#9bc\" font-family=\"sans-serif\" font-size=\"{SVG_FONT}\">{label}</text>",
                top + SVG_FONT
            );
            let y0 = top + SVG_LABEL;
            for (n, e) in outlines.iter().enumerate() {
                let x = x0 + (e.u - u.0) * scale;
                let y = y0 + (v[k].1 - e.v) * scale;
                let green = 90 + (120 * n / outlines.len().max(1)) as u32;
                let _ = writeln!(
                    body,
                    "<ellipse cx=\"{x:.1}\" cy=\"{y:.1}\" rx=\"{:.1}\" ry=\"{:.1}\" transform=\"rotate({:.1} {x:.1} {y:.1})\" fill=\"rgb(26,{green},153)\" stroke=\"#cde\" stroke-width=\"0.6\"/>",
                    e.rx * scale,
                    e.ry * scale,
                    -e.angle.to_degrees(),
                );
            }
            top = y0 + span(v[k]) * scale + SVG_MARGIN;
        }
        let h = top.ceil();
        let w = SVG_WIDTH;
        let _ = writeln!(
            o,
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" viewBox=\"0 0 {w} {h}\">"
        );
        let _ = writeln!(o, "<rect width=\"100%\" height=\"100%\" fill=\"#0b2233\"/>");
        o.push_str(&body);
        let _ = writeln!(o, "</svg>");
        o
    }

    /// Each link's outline in one view (0: from above, x right and y up;
    /// 1: from the side, x right and z up), in metres.
    fn outlines(links: &[Link], view: usize) -> Vec<Outline> {
        links
            .iter()
            .map(|l| {
                let axis = l.orientation * Vector3::x();
                let (u, v, au, av, minor) = if view == 0 {
                    (l.centre.x, l.centre.y, axis.x, axis.y, l.semi_axes.0)
                } else {
                    (l.centre.x, l.centre.z, axis.x, axis.z, l.semi_axes.1)
                };
                Outline {
                    u,
                    v,
                    // The link's length as seen in this view, never a sliver.
                    rx: l.length / 2.0 * au.hypot(av).max(0.05),
                    ry: minor,
                    angle: av.atan2(au),
                }
            })
            .collect()
    }
}

/// The picture's width (px), its margin, its font size and the strip each
/// view's label takes above it.
const SVG_WIDTH: f64 = 640.0;
const SVG_MARGIN: f64 = 12.0;
const SVG_FONT: f64 = 13.0;
const SVG_LABEL: f64 = 24.0;
/// The most height (px) one view of the body may take.
const SVG_VIEW_MAX: f64 = 220.0;

/// One link drawn in one view: an ellipse centred on (`u`, `v`), semi-axes
/// `rx` along the link and `ry` across it, its long axis `angle` (rad)
/// counter-clockwise from `u`.
struct Outline {
    u: f64,
    v: f64,
    rx: f64,
    ry: f64,
    angle: f64,
}

impl Outline {
    /// Half the width and half the height of its bounding box.
    fn half_extents(&self) -> (f64, f64) {
        let (sin, cos) = self.angle.sin_cos();
        (
            (self.rx * cos).hypot(self.ry * sin),
            (self.rx * sin).hypot(self.ry * cos),
        )
    }
}
