//! Stick figures of a mechanism for its documentation page, drawn at package time as SVG
//! (no script, nothing fetched): the joint origins joined by links along each branch from
//! the fixed base, revolute and continuous joints as circles, prismatic joints as squares,
//! the ends of branches (the links with pose outputs) as diamonds, the base as a triangle;
//! two orthographic views side by side at one scale, axes in metres.
//!
//! Every position comes from the model's own forward kinematics
//! ([`Model::forward_kinematics`], the function the FMU's outputs and energies use), so the
//! picture is the mechanism the FMU runs. Fixed joints, merged away in the model, are drawn
//! where their frames sit on the merged bodies (a bend in a link, no marker). Loop closures
//! and springs are drawn from their points: a bar from the body's origin to each point, a
//! dot where a closure's points meet (two dots and a dashed line where the loop is open), a
//! dashed line for a spring. A mechanism with closures is drawn in its start configuration
//! (its loops closed), not at every joint 0.
//!
//! Views: the vertical is the axis along gravity (z when there is none), drawn increasing
//! upwards; the first view puts the lower-indexed of the two other axes across ("front",
//! x–z for gravity along z), the second the other ("side", y–z); when one of them shows
//! the mechanism edge on (its thinner extent below 5 % of the largest) and the top view
//! shows more, the top view replaces it; a planar mechanism (every point in one plane of
//! the axes) gets that plane's view alone, twice as wide.

use super::page::Pictures;
use super::run::Trajectory;
use super::svg::{label, ticks};
use crate::model::Scene;
use crate::multibody::dynamics::Axis;
use crate::multibody::mechanism::{JointKind, Mechanism};
use crate::multibody::spatial::{add, mat_vec};
use crate::multibody::Model;

fn escape(s: &str) -> String {
    quick_xml::escape::escape(s).into_owned()
}

/// A colour per branch, as the scene plots' (distinguishable on white and in grey print).
const COLOURS: [&str; 8] = [
    "#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf",
];

const AXES: [&str; 3] = ["x", "y", "z"];

/// Plot box of one view (px): width, and the height's bounds.
const VIEW_W: f64 = 300.0;
const VIEW_H_MIN: f64 = 150.0;
const VIEW_H_MAX: f64 = 340.0;
/// Room kept free inside a box's edges for markers and names (px).
const INSET: f64 = 18.0;
/// Left margin (tick labels, the vertical axis' name), gap between the views, right margin.
const LEFT: f64 = 62.0;
const GAP: f64 = 72.0;
const RIGHT: f64 = 16.0;
/// Above the boxes: the title and the views' names.
const TOP: f64 = 48.0;
/// Below them: tick labels, axis names, the legend.
const BOTTOM: f64 = 70.0;
/// Marker sizes (px): circle radius, square half side, diamond half diagonal.
const JOINT_R: f64 = 4.5;
const SQUARE: f64 = 4.5;
const DIAMOND: f64 = 5.0;
/// A loop closure's point: a small filled dot.
const CLOSURE_R: f64 = 3.0;
/// Joint names: font size and a width per character that over-estimates sans-serif's.
const NAME_SIZE: f64 = 10.0;
const CHAR_W: f64 = 6.0;

/// A moving joint as drawn.
#[derive(Clone, Debug)]
struct DrawnJoint {
    name: String,
    kind: JointKind,
    /// The original link it moves (its frame origin is the joint's position).
    link: usize,
}

/// The structure of one mechanism's drawing: made once, drawn at any `q`.
#[derive(Clone, Debug)]
pub struct Skeleton<'a> {
    model: &'a Model,
    /// Per original link: the model body its frame is fixed to (`None`: the base) and its
    /// origin in that body's frame.
    hosts: Vec<(Option<usize>, [f64; 3])>,
    links: Vec<String>,
    /// Runs of original links joined by joints, each from the base or from a link where a
    /// branch forks (the first child continues a run, each further child starts one).
    chains: Vec<Vec<usize>>,
    /// The moving joints in the model's (coordinate) order.
    joints: Vec<DrawnJoint>,
    /// The links with no child: the ends of branches.
    ends: Vec<usize>,
    /// The vertical axis (along gravity).
    up: usize,
    /// The axis normal to the plane the mechanism moves in, when it is planar by its joints:
    /// every rotation about that axis, every translation across it.
    normal: Option<usize>,
}

/// One view: which axis runs across and which up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct View {
    h: usize,
    v: usize,
}

impl View {
    /// "x–z".
    fn axes(self) -> String {
        format!("{}–{}", AXES[self.h], AXES[self.v])
    }

    /// The side it is seen from: −(e_v × e_h) ("−y" for x–z).
    fn from(self) -> String {
        // e_v × e_h for distinct unit axes: ±e_k with k the third axis, + when (v, h, k)
        // is a cyclic order.
        let k = 3 - self.h - self.v;
        let cyclic = (self.v + 1) % 3 == self.h;
        format!("{}{}", if cyclic { "−" } else { "+" }, AXES[k])
    }
}

/// What [`Skeleton::draw`] made.
#[derive(Clone, Debug)]
pub struct Drawing {
    pub svg: String,
    pub width: f64,
    pub height: f64,
    /// "front view x–z (seen from −y) and side view y–z (seen from +x)".
    pub views: String,
    /// Joints whose name found no free place in either view (with `names`).
    pub unnamed: Vec<String>,
}

/// A loop closure's or a spring's two points at one configuration (base frame).
#[derive(Clone, Debug)]
struct PairPoints {
    name: String,
    closure: bool,
    body_a: Option<usize>,
    body_b: Option<usize>,
    a: [f64; 3],
    b: [f64; 3],
    /// The origins of the bodies holding them (the base's: 0).
    origin_a: [f64; 3],
    origin_b: [f64; 3],
}

/// One configuration to draw, and how strongly (1: solid; below: earlier instants).
pub struct Pose<'a> {
    pub q: &'a [f64],
    pub opacity: f64,
}

/// An axis-aligned box (px) for the names' placement.
#[derive(Clone, Copy, Debug)]
struct Rect {
    x0: f64,
    y0: f64,
    x1: f64,
    y1: f64,
}

impl Rect {
    fn around(x: f64, y: f64, r: f64) -> Rect {
        Rect {
            x0: x - r,
            y0: y - r,
            x1: x + r,
            y1: y + r,
        }
    }

    fn overlaps(&self, o: &Rect) -> bool {
        self.x0 < o.x1 && o.x0 < self.x1 && self.y0 < o.y1 && o.y0 < self.y1
    }

    /// Whether the segment `[x0, y0, x1, y1]` passes through the box (Liang–Barsky).
    fn crosses(&self, sg: &[f64; 4]) -> bool {
        let (dx, dy) = (sg[2] - sg[0], sg[3] - sg[1]);
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        for (p, q) in [
            (-dx, sg[0] - self.x0),
            (dx, self.x1 - sg[0]),
            (-dy, sg[1] - self.y0),
            (dy, self.y1 - sg[1]),
        ] {
            if p == 0.0 {
                if q < 0.0 {
                    return false;
                }
            } else {
                let t = q / p;
                if p < 0.0 {
                    t0 = t0.max(t);
                } else {
                    t1 = t1.min(t);
                }
            }
        }
        t0 <= t1
    }

    fn inside(&self, o: &Rect) -> bool {
        o.x0 <= self.x0 && self.x1 <= o.x1 && o.y0 <= self.y0 && self.y1 <= o.y1
    }
}

/// A marker of the key under the views.
#[derive(Clone, Copy, Debug, PartialEq)]
enum KeyMark {
    Revolute,
    Prismatic,
    End,
    Base,
    Closure,
    Spring,
    /// A line at this opacity (an instant of a scene).
    Instant(f64),
}

impl KeyMark {
    /// The marker's SVG centred at (x, y).
    fn draw(self, x: f64, y: f64) -> String {
        let d = DIAMOND;
        match self {
            KeyMark::Revolute => format!(
                "<circle cx=\"{x:.1}\" cy=\"{y:.1}\" r=\"{JOINT_R}\" fill=\"white\" stroke=\"#333\" stroke-width=\"1.8\"/>\n"
            ),
            KeyMark::Prismatic => format!(
                "<rect x=\"{:.1}\" y=\"{:.1}\" width=\"{}\" height=\"{}\" fill=\"white\" stroke=\"#333\" stroke-width=\"1.8\"/>\n",
                x - SQUARE,
                y - SQUARE,
                2.0 * SQUARE,
                2.0 * SQUARE
            ),
            KeyMark::End => format!(
                "<polygon points=\"{:.1},{:.1} {:.1},{:.1} {:.1},{:.1} {:.1},{:.1}\" fill=\"#888\" stroke=\"#333\"/>\n",
                x,
                y - d,
                x + d,
                y,
                x,
                y + d,
                x - d,
                y
            ),
            KeyMark::Base => format!(
                "<polygon points=\"{:.1},{:.1} {:.1},{:.1} {:.1},{:.1}\" fill=\"#888\" stroke=\"#333\"/>\n",
                x,
                y - 5.0,
                x - 7.0,
                y + 5.0,
                x + 7.0,
                y + 5.0
            ),
            KeyMark::Closure => format!(
                "<circle cx=\"{x:.1}\" cy=\"{y:.1}\" r=\"{CLOSURE_R}\" fill=\"#333\"/>\n"
            ),
            KeyMark::Spring => format!(
                "<line x1=\"{:.1}\" x2=\"{:.1}\" y1=\"{y:.1}\" y2=\"{y:.1}\" stroke=\"#555\" stroke-width=\"1.5\" stroke-dasharray=\"4 3\"/>\n",
                x - 8.0,
                x + 8.0
            ),
            KeyMark::Instant(opacity) => format!(
                "<line x1=\"{:.1}\" x2=\"{:.1}\" y1=\"{y:.1}\" y2=\"{y:.1}\" stroke=\"#333\" stroke-width=\"2.5\" opacity=\"{opacity}\"/>\n",
                x - 7.0,
                x + 7.0
            ),
        }
    }
}

/// Where each key item's marker goes: left to right from `LEFT` on the row at `y`, a new
/// row (16 px lower) where the next item would pass `right`.
fn key_layout(items: &[(KeyMark, String)], y: f64, right: f64) -> Vec<(f64, f64)> {
    let (mut x, mut y) = (LEFT, y);
    let mut at = Vec::with_capacity(items.len());
    for (_, text) in items {
        let w = 34.0 + 5.8 * text.chars().count() as f64;
        if x > LEFT && x + w - 24.0 > right {
            x = LEFT;
            y += 16.0;
        }
        at.push((x, y));
        x += w;
    }
    at
}

impl<'a> Skeleton<'a> {
    /// The key's items: the markers this mechanism uses, then the caller's instants.
    fn key_items(&self, legend: &[(f64, String)]) -> Vec<(KeyMark, String)> {
        let has = |k: JointKind| self.joints.iter().any(|j| j.kind == k);
        let mut items = Vec::new();
        if self.joints.iter().any(|j| j.kind != JointKind::Prismatic) {
            items.push((KeyMark::Revolute, "revolute / continuous".to_string()));
        }
        if has(JointKind::Prismatic) {
            items.push((KeyMark::Prismatic, "prismatic".to_string()));
        }
        items.push((KeyMark::End, "end of a branch".to_string()));
        items.push((KeyMark::Base, "base".to_string()));
        if !self.model.closures.is_empty() {
            items.push((KeyMark::Closure, "loop closure".to_string()));
        }
        if !self.model.springs.is_empty() {
            items.push((KeyMark::Spring, "spring".to_string()));
        }
        items.extend(
            legend
                .iter()
                .map(|(o, t)| (KeyMark::Instant(*o), t.clone())),
        );
        items
    }

    /// The drawing of `mechanism` (as declared, fixed joints included) whose merged model
    /// is `model`; `None` when they do not match (a mechanism that does not validate).
    pub fn new(mechanism: &Mechanism, model: &'a Model) -> Option<Skeleton<'a>> {
        let merged = mechanism.merge_fixed().ok()?;
        let tree = mechanism.validate().ok()?;
        let hosts = merged
            .frames
            .iter()
            .map(|f| {
                let body = model.bodies.iter().position(|b| *b == f.body);
                (body, f.offset.xyz)
            })
            .collect();
        let body = |name: &str| mechanism.body_index(name);
        let mut chains = vec![vec![tree.root]];
        fn walk(
            m: &Mechanism,
            tree: &crate::multibody::mechanism::Tree,
            b: usize,
            chain: usize,
            chains: &mut Vec<Vec<usize>>,
        ) {
            for (k, &j) in tree.child_joints[b].iter().enumerate() {
                let c = m.body_index(&m.joints[j].child).expect("validated");
                let here = if k == 0 {
                    chain
                } else {
                    chains.push(vec![b]);
                    chains.len() - 1
                };
                chains[here].push(c);
                walk(m, tree, c, here, chains);
            }
        }
        walk(mechanism, &tree, tree.root, 0, &mut chains);
        chains.retain(|c| c.len() > 1);
        let mut joints = Vec::new();
        for (name, moved) in model.joints.iter().zip(&model.bodies) {
            let joint = mechanism.joints.iter().find(|j| j.name == *name)?;
            joints.push(DrawnJoint {
                name: name.clone(),
                kind: joint.kind,
                link: body(moved)?,
            });
        }
        let ends = (0..mechanism.bodies.len())
            .filter(|&b| b != tree.root && tree.child_joints[b].is_empty())
            .collect();
        let g = model.gravity;
        let up = if g.iter().all(|c| *c == 0.0) {
            2
        } else {
            (0..3)
                .max_by(|&a, &b| g[a].abs().total_cmp(&g[b].abs()))
                .unwrap_or(2)
        };
        let poses = model.forward_kinematics(&vec![0.0; model.nq()]);
        let normal = (0..3).find(|&k| {
            (0..model.nq()).all(|i| {
                let along = mat_vec(&poses[i].0, &model.axis[i])[k].abs();
                match model.kinds[i] {
                    Axis::Rotation => along > 1.0 - 1e-9,
                    Axis::Translation => along < 1e-9,
                }
            })
        });
        Some(Skeleton {
            model,
            normal,
            hosts,
            links: mechanism.bodies.iter().map(|b| b.name.clone()).collect(),
            chains,
            joints,
            ends,
            up,
        })
    }

    /// The number of moving joints drawn (one marker each per view and pose).
    pub fn joint_count(&self) -> usize {
        self.joints.len()
    }

    /// Every original link's frame origin in the base frame at `q`, from the model's
    /// forward kinematics (a moving joint's position is its child link's origin).
    pub fn positions(&self, q: &[f64]) -> Vec<[f64; 3]> {
        let poses = self.model.forward_kinematics(q);
        self.hosts
            .iter()
            .map(|(host, offset)| match host {
                None => *offset,
                Some(b) => {
                    let (r, p) = &poses[*b];
                    add(p, &mat_vec(r, offset))
                }
            })
            .collect()
    }

    /// The loop closures' and springs' points at `q`, in the base frame: per pair, the
    /// origin of the body holding each point (the base's origin for the base), the point
    /// of body A and the point of body B. Closures first, then springs.
    fn pair_points(&self, q: &[f64]) -> Vec<PairPoints> {
        let poses = self.model.forward_kinematics(q);
        let at = |body: Option<usize>, p: &[f64; 3]| match body {
            None => (*p, [0.0; 3]),
            Some(b) => {
                let (r, o) = &poses[b];
                (add(o, &mat_vec(r, p)), *o)
            }
        };
        let m = self.model;
        m.closures
            .iter()
            .map(|c| (c, true))
            .chain(m.springs.iter().map(|sp| (sp, false)))
            .map(|(pair, closure)| {
                let (a, origin_a) = at(pair.body_a, &pair.point_a);
                let (b, origin_b) = at(pair.body_b, &pair.point_b);
                PairPoints {
                    name: pair.name.clone(),
                    closure,
                    body_a: pair.body_a,
                    body_b: pair.body_b,
                    a,
                    b,
                    origin_a,
                    origin_b,
                }
            })
            .collect()
    }

    /// The original link whose frame is model body `body`'s (the merged body keeps the
    /// name of the link it starts from).
    fn link_of(&self, body: usize) -> Option<usize> {
        let name = self.model.bodies.get(body)?;
        self.links.iter().position(|l| l == name)
    }

    /// The two views that show the most of these points (see the module's doc).
    fn views(&self, points: &[[f64; 3]]) -> Vec<View> {
        let others: Vec<usize> = (0..3).filter(|&a| a != self.up).collect();
        let front = View {
            h: others[0],
            v: self.up,
        };
        let side = View {
            h: others[1],
            v: self.up,
        };
        let top = View {
            h: others[0],
            v: others[1],
        };
        let span = |a: usize| {
            let lo = points.iter().map(|p| p[a]).fold(f64::INFINITY, f64::min);
            let hi = points
                .iter()
                .map(|p| p[a])
                .fold(f64::NEG_INFINITY, f64::max);
            (hi - lo).max(0.0)
        };
        let largest = (0..3).map(span).fold(0.0, f64::max);
        // A planar mechanism (its joints move it in a plane of the axes, and every point is
        // in that plane): that plane's view alone, twice as wide; the others would see it
        // edge on. (A spatial arm that happens to lie in a plane keeps two views.)
        if let Some(flat) = self.normal.filter(|&a| span(a) <= 1e-9 * largest) {
            return vec![[front, side, top]
                .into_iter()
                .find(|v| v.h != flat && v.v != flat)
                .unwrap_or(front)];
        }
        let thin = |v: View| span(v.h).min(span(v.v));
        let (tf, ts, tt) = (thin(front), thin(side), thin(top));
        if tf.min(ts) < 0.05 * largest && tt > tf.min(ts) {
            if ts <= tf {
                return vec![front, top];
            }
            return vec![top, side];
        }
        vec![front, side]
    }

    /// The SVG of these poses (the faint ones first, the solid ones over them), with the
    /// joints' names on the solid ones where they find room when `names`; `legend`: the
    /// line under the views (the instants of a scene), after the markers' key.
    pub fn draw(
        &self,
        title: &str,
        poses: &[Pose],
        names: bool,
        legend: &[(f64, String)],
    ) -> Drawing {
        let placed: Vec<(Vec<[f64; 3]>, f64)> = poses
            .iter()
            .map(|p| (self.positions(p.q), p.opacity))
            .collect();
        let pairs: Vec<Vec<PairPoints>> = poses.iter().map(|p| self.pair_points(p.q)).collect();
        let mut all: Vec<[f64; 3]> = vec![[0.0; 3]];
        for (pts, _) in &placed {
            all.extend(pts.iter().copied());
        }
        for pp in pairs.iter().flatten() {
            all.extend([pp.a, pp.b]);
        }
        let views = self.views(&all);
        let range = |a: usize| {
            let lo = all.iter().map(|p| p[a]).fold(f64::INFINITY, f64::min);
            let hi = all.iter().map(|p| p[a]).fold(f64::NEG_INFINITY, f64::max);
            (lo, hi)
        };
        // One scale for both views and both axes: the largest at which every view fits.
        let largest = (0..3)
            .map(|a| range(a).1 - range(a).0)
            .fold(0.0, f64::max)
            .max(1e-3);
        let view_w = if views.len() == 1 {
            2.0 * VIEW_W + GAP
        } else {
            VIEW_W
        };
        let usable_w = view_w - 2.0 * INSET;
        let usable_h = VIEW_H_MAX - 2.0 * INSET;
        let mut scale = f64::INFINITY;
        for v in &views {
            let (h0, h1) = range(v.h);
            let (v0, v1) = range(v.v);
            scale = scale
                .min(usable_w / (h1 - h0).max(1e-9 * largest))
                .min(usable_h / (v1 - v0).max(1e-9 * largest));
        }
        if !scale.is_finite() || scale <= 0.0 {
            scale = usable_w / largest;
        }
        let tallest = views
            .iter()
            .map(|v| range(v.v).1 - range(v.v).0)
            .fold(0.0, f64::max);
        let view_h = (tallest * scale + 2.0 * INSET).clamp(VIEW_H_MIN, VIEW_H_MAX);
        let width = LEFT + 2.0 * VIEW_W + GAP + RIGHT;
        let key_at = key_layout(&self.key_items(legend), TOP + view_h + 55.0, width - RIGHT);
        let rows = key_at
            .last()
            .map_or(0.0, |&(_, y)| y - (TOP + view_h + 55.0));
        let height = TOP + view_h + BOTTOM + rows;
        let mut s = format!(
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{width}\" height=\"{height}\" viewBox=\"0 0 {width} {height}\" font-family=\"sans-serif\" font-size=\"12\">\n<title>{}</title>\n<rect width=\"{width}\" height=\"{height}\" fill=\"white\"/>\n<text x=\"{:.1}\" y=\"18\" text-anchor=\"middle\" font-size=\"14\">{}</text>\n",
            escape(title),
            width / 2.0,
            escape(title)
        );
        let view_names = ["front view", "side view"];
        let mut named = vec![false; self.joints.len()];
        let mut described = Vec::new();
        for (k, view) in views.iter().enumerate() {
            let left = LEFT + k as f64 * (view_w + GAP);
            let (h0, h1) = range(view.h);
            let (v0, v1) = range(view.v);
            let (ch, cv) = (0.5 * (h0 + h1), 0.5 * (v0 + v1));
            let px = |h: f64| left + 0.5 * view_w + (h - ch) * scale;
            let py = |v: f64| TOP + 0.5 * view_h - (v - cv) * scale;
            let name = if view.v == self.up {
                view_names[k]
            } else {
                "top view"
            };
            described.push(format!(
                "{name} {} (seen from {})",
                view.axes(),
                view.from()
            ));
            s.push_str(&format!(
                "<g class=\"view\" data-view=\"{}\" data-h=\"{}\" data-v=\"{}\">\n<text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"middle\">{name} {} (seen from {})</text>\n",
                view.axes(),
                AXES[view.h],
                AXES[view.v],
                left + 0.5 * view_w,
                TOP - 8.0,
                view.axes(),
                view.from()
            ));
            // Grid and ticks over the visible ranges.
            let half_w = 0.5 * view_w / scale;
            let half_h = 0.5 * view_h / scale;
            for t in ticks(ch - half_w, ch + half_w) {
                let x = px(t);
                s.push_str(&format!(
                    "<line class=\"htick\" x1=\"{x:.2}\" x2=\"{x:.2}\" y1=\"{TOP}\" y2=\"{:.2}\" stroke=\"#eee\"/><text x=\"{x:.2}\" y=\"{:.1}\" text-anchor=\"middle\">{}</text>\n",
                    TOP + view_h,
                    TOP + view_h + 15.0,
                    label(t)
                ));
            }
            for t in ticks(cv - half_h, cv + half_h) {
                let y = py(t);
                s.push_str(&format!(
                    "<line class=\"vtick\" x1=\"{left}\" x2=\"{:.2}\" y1=\"{y:.2}\" y2=\"{y:.2}\" stroke=\"#eee\"/><text x=\"{:.1}\" y=\"{:.2}\" text-anchor=\"end\">{}</text>\n",
                    left + view_w,
                    left - 5.0,
                    y + 4.0,
                    label(t)
                ));
            }
            s.push_str(&format!(
                "<rect x=\"{left}\" y=\"{TOP}\" width=\"{view_w}\" height=\"{view_h:.2}\" fill=\"none\" stroke=\"#333\"/>\n<text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"middle\">{} (m)</text>\n<text transform=\"translate({:.1} {:.1}) rotate(-90)\" text-anchor=\"middle\">{} (m)</text>\n",
                left + 0.5 * view_w,
                TOP + view_h + 31.0,
                AXES[view.h],
                left - 44.0,
                TOP + 0.5 * view_h,
                AXES[view.v]
            ));
            // The base: a triangle under its origin.
            let (bx, by) = (px(0.0), py(0.0));
            s.push_str(&format!(
                "<polygon class=\"base\" points=\"{:.2},{:.2} {:.2},{:.2} {:.2},{:.2}\" fill=\"#888\" stroke=\"#333\"/>\n",
                bx,
                by,
                bx - 7.0,
                by + 10.0,
                bx + 7.0,
                by + 10.0
            ));
            // The poses, faint first.
            let mut order: Vec<usize> = (0..placed.len()).collect();
            order.sort_by(|&a, &b| placed[a].1.total_cmp(&placed[b].1));
            let solid = placed.iter().map(|p| p.1).fold(0.0, f64::max);
            let mut marks: Vec<Rect> = Vec::new();
            let mut label_at: Vec<(usize, f64, f64)> = Vec::new();
            let mut segments: Vec<[f64; 4]> = Vec::new();
            for &i in &order {
                let (pts, opacity) = &placed[i];
                let at = |b: usize| (px(pts[b][view.h]), py(pts[b][view.v]));
                s.push_str(&format!(
                    "<g class=\"pose\" data-pose=\"{i}\" opacity=\"{opacity}\">\n"
                ));
                for (c, chain) in self.chains.iter().enumerate() {
                    let colour = COLOURS[c % COLOURS.len()];
                    let points: Vec<String> = chain
                        .iter()
                        .map(|&b| {
                            let (x, y) = at(b);
                            format!("{x:.2},{y:.2}")
                        })
                        .collect();
                    if *opacity == solid {
                        for w in chain.windows(2) {
                            let ((x0, y0), (x1, y1)) = (at(w[0]), at(w[1]));
                            segments.push([x0, y0, x1, y1]);
                        }
                    }
                    s.push_str(&format!(
                        "<polyline class=\"link\" fill=\"none\" stroke=\"{colour}\" stroke-width=\"2.5\" stroke-linejoin=\"round\" points=\"{}\"/>\n",
                        points.join(" ")
                    ));
                }
                let colour_of = |link: usize| {
                    let c = self
                        .chains
                        .iter()
                        .position(|chain| chain[1..].contains(&link))
                        .unwrap_or(0);
                    COLOURS[c % COLOURS.len()]
                };
                // Loop closures and springs: each point joined to the origin of its body
                // (a bar to the point it holds), a closure's points marked by a ring (and
                // joined by a dashed line where the loop is open), a spring a dashed line.
                let flat = |p: &[f64; 3]| (px(p[view.h]), py(p[view.v]));
                for pp in &pairs[i] {
                    for (body, origin, point) in [
                        (pp.body_a, pp.origin_a, pp.a),
                        (pp.body_b, pp.origin_b, pp.b),
                    ] {
                        let Some(link) = body.and_then(|b| self.link_of(b)) else {
                            continue;
                        };
                        let ((x0, y0), (x1, y1)) = (flat(&origin), flat(&point));
                        if *opacity == solid {
                            segments.push([x0, y0, x1, y1]);
                        }
                        s.push_str(&format!(
                            "<line class=\"link\" x1=\"{x0:.2}\" y1=\"{y0:.2}\" x2=\"{x1:.2}\" y2=\"{y1:.2}\" stroke=\"{}\" stroke-width=\"2.5\" stroke-linecap=\"round\"/>\n",
                            colour_of(link)
                        ));
                    }
                    let ((xa, ya), (xb, yb)) = (flat(&pp.a), flat(&pp.b));
                    let open = (xa - xb).hypot(ya - yb) > 0.5;
                    if !pp.closure || open {
                        s.push_str(&format!(
                            "<line class=\"{}\" data-pair=\"{}\" x1=\"{xa:.2}\" y1=\"{ya:.2}\" x2=\"{xb:.2}\" y2=\"{yb:.2}\" stroke=\"{}\" stroke-width=\"1.5\" stroke-dasharray=\"4 3\"/>\n",
                            if pp.closure { "closure-gap" } else { "spring" },
                            escape(&pp.name),
                            if pp.closure { "#d62728" } else { "#555" }
                        ));
                    }
                    if pp.closure {
                        for (x, y) in [(xa, ya), (xb, yb)] {
                            s.push_str(&format!(
                                "<circle class=\"closure\" data-pair=\"{}\" cx=\"{x:.2}\" cy=\"{y:.2}\" r=\"{CLOSURE_R}\" fill=\"#333\" stroke=\"white\" stroke-width=\"1\"/>\n",
                                escape(&pp.name)
                            ));
                            if *opacity == solid {
                                marks.push(Rect::around(x, y, CLOSURE_R + 1.0));
                            }
                            if !open {
                                break;
                            }
                        }
                    }
                }
                for &e in &self.ends {
                    let (x, y) = at(e);
                    let d = DIAMOND;
                    s.push_str(&format!(
                        "<polygon class=\"end\" data-link=\"{}\" points=\"{:.2},{:.2} {:.2},{:.2} {:.2},{:.2} {:.2},{:.2}\" fill=\"{}\" stroke=\"#333\"/>\n",
                        escape(&self.links[e]),
                        x,
                        y - d,
                        x + d,
                        y,
                        x,
                        y + d,
                        x - d,
                        y,
                        colour_of(e)
                    ));
                    if *opacity == solid {
                        marks.push(Rect::around(x, y, d + 1.0));
                    }
                }
                for (j, joint) in self.joints.iter().enumerate() {
                    let (x, y) = at(joint.link);
                    let colour = colour_of(joint.link);
                    let common = format!(
                        "class=\"joint {}\" data-joint=\"{}\" fill=\"white\" stroke=\"{colour}\" stroke-width=\"1.8\"",
                        joint.kind.name(),
                        escape(&joint.name)
                    );
                    match joint.kind {
                        JointKind::Prismatic => s.push_str(&format!(
                            "<rect {common} x=\"{:.2}\" y=\"{:.2}\" width=\"{}\" height=\"{}\"/>\n",
                            x - SQUARE,
                            y - SQUARE,
                            2.0 * SQUARE,
                            2.0 * SQUARE
                        )),
                        _ => s.push_str(&format!(
                            "<circle {common} cx=\"{x:.2}\" cy=\"{y:.2}\" r=\"{JOINT_R}\"/>\n"
                        )),
                    }
                    if *opacity == solid {
                        marks.push(Rect::around(x, y, JOINT_R + 1.0));
                        label_at.push((j, x, y));
                    }
                }
                s.push_str("</g>\n");
            }
            if names {
                let frame = Rect {
                    x0: left + 1.0,
                    y0: TOP + 1.0,
                    x1: left + view_w - 1.0,
                    y1: TOP + view_h - 1.0,
                };
                let mut taken: Vec<Rect> = Vec::new();
                // Joints drawn on one spot (two axes through one point) share one name
                // label: "panda_joint1, panda_joint2".
                let mut spots: Vec<(Vec<usize>, f64, f64)> = Vec::new();
                for (j, x, y) in label_at {
                    match spots
                        .iter_mut()
                        .find(|(_, sx, sy)| (sx - x).abs() < 1.5 && (sy - y).abs() < 1.5)
                    {
                        Some(spot) => spot.0.push(j),
                        None => spots.push((vec![j], x, y)),
                    }
                }
                for (js, x, y) in spots {
                    let text = js
                        .iter()
                        .map(|&j| self.joints[j].name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ");
                    let w = CHAR_W * text.chars().count() as f64;
                    let h = NAME_SIZE + 2.0;
                    let gap = JOINT_R + 3.0;
                    // (anchor, x, baseline y, box's top left): right, left, above, below,
                    // then the diagonals.
                    let d = 0.75 * gap;
                    let candidates = [
                        ("start", x + gap, y + 3.5, x + gap, y - h / 2.0),
                        ("end", x - gap, y + 3.5, x - gap - w, y - h / 2.0),
                        ("middle", x, y - gap - 2.0, x - w / 2.0, y - gap - h),
                        ("middle", x, y + gap + NAME_SIZE, x - w / 2.0, y + gap),
                        ("start", x + d, y - d - 2.0, x + d, y - d - h),
                        ("end", x - d, y - d - 2.0, x - d - w, y - d - h),
                        ("start", x + d, y + d + NAME_SIZE, x + d, y + d),
                        ("end", x - d, y + d + NAME_SIZE, x - d - w, y + d),
                    ];
                    let own = Rect::around(x, y, JOINT_R + 1.0);
                    let fits = |r: &Rect| {
                        r.inside(&frame)
                            && !taken.iter().any(|t| t.overlaps(r))
                            && !marks
                                .iter()
                                .filter(|m| !(m.x0 == own.x0 && m.y0 == own.y0))
                                .any(|m| m.overlaps(r))
                    };
                    let boxed = |(_, _, _, bx, by): (&str, f64, f64, f64, f64)| Rect {
                        x0: bx,
                        y0: by,
                        x1: bx + w,
                        y1: by + h,
                    };
                    // Clear of the links if it can be, else over them (the white halo keeps
                    // it legible), never over a marker or another name.
                    let free = candidates
                        .iter()
                        .copied()
                        .find(|&c| {
                            let r = boxed(c);
                            fits(&r) && !segments.iter().any(|sg| r.crosses(sg))
                        })
                        .or_else(|| candidates.iter().copied().find(|&c| fits(&boxed(c))));
                    if let Some((anchor, tx, ty, bx, by)) = free {
                        taken.push(Rect {
                            x0: bx,
                            y0: by,
                            x1: bx + w,
                            y1: by + h,
                        });
                        for &j in &js {
                            named[j] = true;
                        }
                        s.push_str(&format!(
                            "<text class=\"name\" x=\"{tx:.2}\" y=\"{ty:.2}\" text-anchor=\"{anchor}\" font-size=\"{NAME_SIZE}\" stroke=\"white\" stroke-width=\"3\" paint-order=\"stroke\">{}</text>\n",
                            escape(&text)
                        ));
                    }
                }
            }
            s.push_str("</g>\n");
        }
        // The key: the markers this drawing uses, then the caller's line (the instants),
        // wrapped onto further rows where a row is full.
        for ((mark, text), (x, y)) in self.key_items(legend).into_iter().zip(&key_at) {
            s.push_str(&mark.draw(*x, *y));
            s.push_str(&format!(
                "<text x=\"{:.1}\" y=\"{:.1}\" font-size=\"11\">{}</text>\n",
                x + 10.0,
                y + 4.0,
                escape(&text)
            ));
        }
        s.push_str("</svg>\n");
        Drawing {
            svg: s,
            width,
            height,
            views: described.join(" and "),
            unnamed: self
                .joints
                .iter()
                .zip(&named)
                .filter(|(_, n)| !**n)
                .map(|(j, _)| j.name.clone())
                .collect(),
        }
    }
}

/// A mechanism's pictures on its page ([`Pictures`]): the reference configuration after
/// the description, and each scene at its start, middle and end.
pub struct MechanismPictures<'a> {
    pub name: &'a str,
    pub skeleton: Skeleton<'a>,
    /// The configuration the scenes start from (0, or the middle of limits that exclude 0).
    pub start: &'a [f64],
}

fn list(names: &[String]) -> String {
    names
        .iter()
        .map(|n| format!("<code>{}</code>", escape(n)))
        .collect::<Vec<_>>()
        .join(", ")
}

const KEY: &str = "Circles: revolute and continuous joints; squares: prismatic joints; diamonds: the ends of branches (the links whose pose is an output); the triangle: the fixed base. Links join the joint origins along each branch from the base, a colour per branch (fixed joints are bends without a marker).";

impl Pictures for MechanismPictures<'_> {
    fn anchor(&self) -> (&'static str, &'static str) {
        ("mechanism", "Mechanism")
    }

    fn reference(&self) -> (String, Vec<(String, String)>) {
        let sk = &self.skeleton;
        // With loop closures every joint at 0 leaves the loops open: the picture is the
        // start configuration instead, the loops closed by consistent initialisation.
        let closed = !sk.model.closures.is_empty();
        let zero = vec![0.0; sk.joint_count()];
        let q = if closed { self.start } else { &zero[..] };
        let d = sk.draw(
            &if closed {
                format!("{} in its start configuration (loops closed)", self.name)
            } else {
                format!(
                    "{} in its reference configuration (every joint at 0)",
                    self.name
                )
            },
            &[Pose { q, opacity: 1.0 }],
            true,
            &[],
        );
        let moved: Vec<String> = if closed {
            Vec::new()
        } else {
            sk.joints
                .iter()
                .zip(self.start)
                .filter(|(_, q)| **q != 0.0)
                .map(|(j, _)| j.name.clone())
                .collect()
        };
        let configuration = if closed {
            let n = sk.model.closures.len();
            format!(
                "The mechanism in its start configuration (the start values, the dependent joints solved so that the {} loop{} close{}; every joint at 0 would leave {} open)",
                n,
                if n == 1 { "" } else { "s" },
                if n == 1 { "s" } else { "" },
                if n == 1 { "it" } else { "them" },
            )
        } else {
            "The mechanism with every joint at 0 (the frames as the URDF or the builder wrote them)"
                .to_string()
        };
        let pairs = match (sk.model.closures.is_empty(), sk.model.springs.is_empty()) {
            (true, true) => "",
            (false, true) => " A loop closure's point is a dot, on the bar from its body's origin.",
            (true, false) => " A spring is a dashed line between its points.",
            (false, false) => " A loop closure's point is a dot, on the bar from its body's origin; a spring a dashed line between its points.",
        };
        let mut caption = format!(
            "{configuration}, placed by the FMU's own forward kinematics: {}, at one scale, in metres. {KEY}{pairs} {} moving joint{}, {} end{} of branches.",
            d.views,
            sk.joint_count(),
            if sk.joint_count() == 1 { "" } else { "s" },
            sk.ends.len(),
            if sk.ends.len() == 1 { "" } else { "s" },
        );
        if !d.unnamed.is_empty() {
            caption.push_str(&format!(
                " Not named for want of room: {}.",
                list(&d.unnamed)
            ));
        }
        if !moved.is_empty() {
            caption.push_str(&format!(
                " The scenes start elsewhere: {} at the middle of {} limits (0 is not strictly inside them).",
                list(&moved),
                if moved.len() == 1 { "its" } else { "their" }
            ));
        }
        let html = format!(
            "<h2 id=\"mechanism\">The mechanism</h2>\n<figure><img src=\"mechanism.svg\" width=\"{}\" height=\"{}\" alt=\"{} in its {}: a stick figure in two views\"><figcaption>{caption}</figcaption></figure>\n",
            d.width,
            d.height,
            escape(self.name),
            if closed {
                "start configuration"
            } else {
                "reference configuration"
            }
        );
        (html, vec![("documentation/mechanism.svg".into(), d.svg)])
    }

    fn scene(&self, scene: &Scene, traj: &Trajectory) -> (String, Vec<(String, String)>) {
        let sk = &self.skeleton;
        let columns: Option<Vec<usize>> = sk
            .joints
            .iter()
            .map(|j| traj.names.iter().position(|n| *n == j.name))
            .collect();
        let (Some(columns), Some(last)) = (columns, traj.t.len().checked_sub(1)) else {
            return (String::new(), Vec::new());
        };
        let mut instants = vec![0, last / 2, last];
        instants.dedup();
        let opacities: &[f64] = match instants.len() {
            1 => &[1.0],
            2 => &[0.3, 1.0],
            _ => &[0.22, 0.5, 1.0],
        };
        let qs: Vec<Vec<f64>> = instants
            .iter()
            .map(|&k| columns.iter().map(|&c| traj.columns[c][k]).collect())
            .collect();
        let poses: Vec<Pose> = qs
            .iter()
            .zip(opacities)
            .map(|(q, &opacity)| Pose { q, opacity })
            .collect();
        let times: Vec<String> = instants
            .iter()
            .map(|&k| format!("{} s", label(traj.t[k])))
            .collect();
        let legend: Vec<(f64, String)> = opacities
            .iter()
            .zip(&times)
            .map(|(&o, t)| (o, format!("t = {t}")))
            .collect();
        let d = sk.draw(
            &format!(
                "{} — {}: the mechanism at t = {}",
                self.name,
                scene.name,
                times.join(", ")
            ),
            &poses,
            false,
            &legend,
        );
        let file = format!("scene_{}_mechanism.svg", scene.name);
        let html = format!(
            "<figure><img src=\"{file}\" width=\"{}\" height=\"{}\" alt=\"{} scene {}: the mechanism at three instants\"><figcaption>The mechanism at t = {} of this run (fainter: earlier), by the forward kinematics of the recorded joint positions: {}, at one scale, in metres.</figcaption></figure>\n",
            d.width,
            d.height,
            escape(self.name),
            escape(scene.name),
            times.join(", "),
            d.views
        );
        (html, vec![(format!("documentation/{file}"), d.svg)])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::multibody::urdf;
    use quick_xml::events::Event;
    use std::collections::HashMap;

    /// Two branches from a link: a revolute joint about z, then a prismatic joint along x,
    /// a continuous joint about y and a fixed tool; and a revolute joint about x. Offsets
    /// along every axis, so each view sees something.
    const URDF: &str = r#"<?xml version="1.0"?>
<robot name="small">
  <link name="base"/>
  <link name="turret"><inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
  <link name="slide"><inertial><origin xyz="0.05 0 0"/><mass value="0.5"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
  <link name="wrist"><inertial><origin xyz="0 0 0.05"/><mass value="0.3"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
  <link name="tool"/>
  <link name="flap"><inertial><origin xyz="0 -0.05 0"/><mass value="0.2"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
  <joint name="yaw" type="revolute">
    <parent link="base"/><child link="turret"/>
    <origin xyz="0 0 0.3"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="10" velocity="1"/>
  </joint>
  <joint name="reach" type="prismatic">
    <parent link="turret"/><child link="slide"/>
    <origin xyz="0.2 0.1 0" rpy="0 0 0.3"/><axis xyz="1 0 0"/>
    <limit lower="-0.1" upper="0.3" effort="10" velocity="1"/>
  </joint>
  <joint name="roll" type="continuous">
    <parent link="slide"/><child link="wrist"/>
    <origin xyz="0 0 0.25"/><axis xyz="0 1 0"/>
  </joint>
  <joint name="tool_mount" type="fixed">
    <parent link="wrist"/><child link="tool"/>
    <origin xyz="0.1 0 0.05"/>
  </joint>
  <joint name="hinge" type="revolute">
    <parent link="turret"/><child link="flap"/>
    <origin xyz="0 -0.15 0.05"/><axis xyz="1 0 0"/>
    <limit lower="-1" upper="1" effort="5" velocity="1"/>
  </joint>
</robot>
"#;

    /// One view of a drawing read back: its axes, (value, px) of its ticks across and up,
    /// and each marker's centre by class and name.
    #[derive(Default, Debug)]
    struct ReadView {
        h: String,
        v: String,
        hticks: Vec<(f64, f64)>,
        vticks: Vec<(f64, f64)>,
        /// (class, name) → centres (one per pose).
        marks: HashMap<(String, String), Vec<(f64, f64)>>,
        names: Vec<String>,
    }

    fn read(svg: &str) -> Vec<ReadView> {
        let mut reader = quick_xml::Reader::from_str(svg);
        let mut views: Vec<ReadView> = Vec::new();
        // A tick line waits for its label's text; a name element for its text.
        let mut pending: Option<(bool, f64)> = None;
        let mut in_name = false;
        loop {
            let event = reader.read_event().expect("well-formed SVG");
            match &event {
                Event::Eof => break,
                Event::Start(e) | Event::Empty(e) => {
                    let mut a: HashMap<String, String> = HashMap::new();
                    for attr in e.attributes().flatten() {
                        let key: &str = attr.key.as_ref();
                        let value = quick_xml::escape::unescape(&attr.value).unwrap();
                        a.insert(key.to_string(), value.into_owned());
                    }
                    let num = |k: &str| a[k].parse::<f64>().unwrap();
                    let class = a.get("class").cloned().unwrap_or_default();
                    let tag = e.name();
                    let tag: &str = tag.as_ref();
                    in_name = class == "name";
                    if class == "view" {
                        views.push(ReadView {
                            h: a["data-h"].clone(),
                            v: a["data-v"].clone(),
                            ..Default::default()
                        });
                    } else if class == "htick" {
                        pending = Some((true, num("x1")));
                    } else if class == "vtick" {
                        pending = Some((false, num("y1")));
                    } else if class.starts_with("joint") || class == "end" || class == "closure" {
                        let name = a
                            .get("data-joint")
                            .or_else(|| a.get("data-link"))
                            .or_else(|| a.get("data-pair"))
                            .unwrap()
                            .clone();
                        let centre = match tag {
                            "circle" => (num("cx"), num("cy")),
                            "rect" => (
                                num("x") + 0.5 * num("width"),
                                num("y") + 0.5 * num("height"),
                            ),
                            "polygon" => {
                                // The diamond: top, right, bottom, left.
                                let p: Vec<f64> = a["points"]
                                    .split([' ', ','])
                                    .map(|v| v.parse().unwrap())
                                    .collect();
                                (p[0], 0.5 * (p[1] + p[5]))
                            }
                            other => panic!("marker <{other}>"),
                        };
                        views
                            .last_mut()
                            .unwrap()
                            .marks
                            .entry((class, name))
                            .or_default()
                            .push(centre);
                    }
                }
                Event::Text(t) => {
                    let raw: &str = t.as_ref();
                    let text = quick_xml::escape::unescape(raw).unwrap().into_owned();
                    if let Some((across, px)) = pending.take() {
                        let value: f64 = text.replace('−', "-").parse().unwrap();
                        let view = views.last_mut().unwrap();
                        if across {
                            view.hticks.push((value, px));
                        } else {
                            view.vticks.push((value, px));
                        }
                    } else if in_name {
                        views.last_mut().unwrap().names.push(text);
                        in_name = false;
                    }
                }
                _ => {}
            }
        }
        views
    }

    /// px = a + b · value through the first and last ticks, after checking every tick lies
    /// on it: (a, b).
    fn axis(ticks: &[(f64, f64)]) -> (f64, f64) {
        assert!(ticks.len() >= 2, "{ticks:?}");
        let (v0, p0) = ticks[0];
        let (v1, p1) = ticks[ticks.len() - 1];
        let b = (p1 - p0) / (v1 - v0);
        let a = p0 - b * v0;
        for (v, p) in ticks {
            assert!(
                (a + b * v - p).abs() < 0.02,
                "tick {v} at {p}, not {}",
                a + b * v
            );
        }
        (a, b)
    }

    fn index(axis: &str) -> usize {
        AXES.iter().position(|a| *a == axis).unwrap()
    }

    #[test]
    fn the_joint_markers_sit_where_forward_kinematics_puts_the_joints() {
        let mechanism = urdf::parse(URDF, "small.urdf").unwrap();
        let model = Model::new(&mechanism).unwrap();
        let skeleton = Skeleton::new(&mechanism, &model).unwrap();
        assert_eq!(model.joints, ["yaw", "reach", "roll", "hinge"]);
        for q in [vec![0.0; 4], vec![0.4, 0.05, -0.7, 0.3]] {
            let d = skeleton.draw(
                "small",
                &[Pose {
                    q: &q,
                    opacity: 1.0,
                }],
                true,
                &[],
            );
            let views = read(&d.svg);
            assert_eq!(views.len(), 2, "two views");
            // Gravity along z: front x–z and side y–z.
            assert_eq!((views[0].h.as_str(), views[0].v.as_str()), ("x", "z"));
            assert_eq!((views[1].h.as_str(), views[1].v.as_str()), ("y", "z"));
            assert!(
                d.views.contains("x–z") && d.views.contains("y–z"),
                "{}",
                d.views
            );
            let fk = model.forward_kinematics(&q);
            let tips = model.tip_poses(&q);
            let mut scales = Vec::new();
            for view in &views {
                let (ah, bh) = axis(&view.hticks);
                let (av, bv) = axis(&view.vticks);
                // Equal scales, up is up.
                assert!(bh > 0.0 && bv < 0.0, "{bh} {bv}");
                assert!((bh + bv).abs() < 1e-3 * bh, "scales {bh} and {}", -bv);
                scales.push(bh);
                let (h, v) = (index(&view.h), index(&view.v));
                let back = |(x, y): (f64, f64)| ((x - ah) / bh, (y - av) / bv);
                // 0.05 px of rounding in the positions and ticks, in metres.
                let tol = 0.05 / bh;
                // One marker per moving joint, of its kind, at its forward-kinematics place.
                let joints: Vec<_> = view
                    .marks
                    .keys()
                    .filter(|(c, _)| c.starts_with("joint"))
                    .collect();
                assert_eq!(joints.len(), 4, "{:?}", view.marks.keys());
                for (i, name) in model.joints.iter().enumerate() {
                    let kind = mechanism
                        .joints
                        .iter()
                        .find(|j| j.name == *name)
                        .unwrap()
                        .kind
                        .name();
                    let key = (format!("joint {kind}"), name.clone());
                    let centres = &view.marks[&key];
                    assert_eq!(centres.len(), 1, "{key:?}");
                    let (x, y) = back(centres[0]);
                    let p = fk[i].1;
                    assert!(
                        (x - p[h]).abs() < tol && (y - p[v]).abs() < tol,
                        "{name} at ({x}, {y}) in {}–{}, forward kinematics ({}, {})",
                        view.h,
                        view.v,
                        p[h],
                        p[v]
                    );
                }
                // The ends of branches where the FMU's pose outputs put them (the tool is on
                // a fixed joint, folded into the wrist).
                for (tip, (p, _)) in model.tips.iter().zip(&tips) {
                    let centres = &view.marks[&("end".to_string(), tip.name.clone())];
                    let (x, y) = back(centres[0]);
                    assert!(
                        (x - p[h]).abs() < tol && (y - p[v]).abs() < tol,
                        "end {} at ({x}, {y}), pose output ({}, {})",
                        tip.name,
                        p[h],
                        p[v]
                    );
                }
                assert_eq!(
                    view.marks.keys().filter(|(c, _)| c == "end").count(),
                    2,
                    "tool and flap"
                );
                // Names where there is room: here, with few joints, somewhere each.
                for n in view.names.iter().flat_map(|n| n.split(", ")) {
                    assert!(model.joints.contains(&n.to_string()), "{n}");
                }
            }
            assert!(
                (scales[0] - scales[1]).abs() < 1e-3 * scales[0],
                "{scales:?}"
            );
            assert!(d.unnamed.is_empty(), "{:?}", d.unnamed);
        }
    }

    #[test]
    fn a_mechanism_seen_edge_on_gets_the_top_view_instead() {
        let mechanism = urdf::parse(URDF, "small.urdf").unwrap();
        let model = Model::new(&mechanism).unwrap();
        let skeleton = Skeleton::new(&mechanism, &model).unwrap();
        // Points nearly in a horizontal plane (gravity along z; 1 % of the largest extent
        // up): the side view y–z sees almost a line, the top view x–y replaces it; the
        // same exactly in the plane (this mechanism's joints are not planar: it only
        // happens to lie flat).
        let thin = [[0.0, 0.0, 0.0], [1.0, 0.5, 0.015], [1.5, 0.2, 0.0]];
        let flat = [[0.0, 0.0, 0.0], [1.0, 0.5, 0.0], [1.5, 0.2, 0.0]];
        for points in [thin, flat] {
            let views = skeleton.views(&points);
            assert_eq!(views, [View { h: 0, v: 2 }, View { h: 0, v: 1 }]);
            assert_eq!(views[1].from(), "+z");
        }
        // In the vertical x–z plane: front and side as usual (the top sees a line too).
        let upright = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.5], [1.5, 0.0, 0.2]];
        assert_eq!(
            skeleton.views(&upright),
            [View { h: 0, v: 2 }, View { h: 1, v: 2 }]
        );
        assert_eq!(skeleton.normal, None);
        assert_eq!(View { h: 0, v: 2 }.from(), "−y");
        assert_eq!(View { h: 1, v: 2 }.from(), "+x");
    }

    /// A closed loop (FourBar, planar in x–y): one view, its plane's; the reference picture
    /// is the start configuration with the loop closed (one dot where the closure's two
    /// points meet, no gap line), the dot where forward kinematics puts the coupler's end;
    /// the same mechanism with its loop open (every joint at 0) shows a gap between two dots.
    #[test]
    fn a_closed_loop_is_drawn_closed_in_its_plane() {
        use crate::multibody::fmu::Declared;
        use crate::systems::four_bar::FourBarMechanism;
        let built = FourBarMechanism::built();
        let skeleton = Skeleton::new(&built.mechanism, &built.model).unwrap();
        let mut start = vec![0.0; built.start.len()];
        for (k, &i) in built.order.iter().enumerate() {
            start[i] = built.start[k];
        }
        let pictures = MechanismPictures {
            name: "FourBar",
            skeleton: skeleton.clone(),
            start: &start,
        };
        let (html, files) = pictures.reference();
        assert!(html.contains("start configuration"), "{html}");
        let svg = &files[0].1;
        assert_eq!(skeleton.normal, Some(2), "FourBar turns about z");
        let views = read(svg);
        assert_eq!(views.len(), 1, "a planar mechanism gets one view");
        assert_eq!((views[0].h.as_str(), views[0].v.as_str()), ("x", "y"));
        let (ah, bh) = axis(&views[0].hticks);
        let (av, bv) = axis(&views[0].vticks);
        let closure = &built.model.closures[0];
        let dots = &views[0].marks[&("closure".to_string(), closure.name.clone())];
        assert_eq!(dots.len(), 1, "the loop is closed: one dot");
        assert!(!svg.contains("closure-gap"));
        let pp = &skeleton.pair_points(&start)[0];
        let (x, y) = dots[0];
        assert!((x - (ah + bh * pp.a[0])).abs() < 0.02, "{x} vs {}", pp.a[0]);
        assert!((y - (av + bv * pp.a[1])).abs() < 0.02, "{y} vs {}", pp.a[1]);
        // (its points coincide in the model, to rounding)
        assert!((0..3).all(|k| (pp.a[k] - pp.b[k]).abs() < 1e-12), "{pp:?}");
        let zero = vec![0.0; start.len()];
        let open = skeleton.draw(
            "open",
            &[Pose {
                q: &zero,
                opacity: 1.0,
            }],
            false,
            &[],
        );
        assert!(open.svg.contains("closure-gap"));
        let views = read(&open.svg);
        assert_eq!(
            views[0].marks[&("closure".to_string(), closure.name.clone())].len(),
            2
        );
    }
}
