//! The tree as a picture: an icicle diagram of a structure's outline. The root is the top
//! row, spanning the whole width; each row below holds the children of the row above, side
//! by side within their parent's span, each as wide as its share of a chosen quantity
//! (triangles under it, its subtree's share of the SAH cost, or an equal share). A node too
//! narrow to see is drawn folded, its subtree left out, so even a tree of a million nodes
//! is a few thousand cells. Each cell also carries the quantity its colour shows.

use super::{Outline, OutlineNode};

/// What a node's width is proportional to, among its siblings.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, clap::ValueEnum)]
pub enum Width {
    /// The triangle references under it.
    #[default]
    Triangles,
    /// Its subtree's share of the tree's SAH cost: where the cost lives.
    Sah,
    /// An equal share: the tree's shape alone.
    Uniform,
    /// Its subtree's share of the nodes the frame's rays visited (measured).
    Visits,
}

/// What a cell's colour shows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, clap::ValueEnum)]
pub enum Shade {
    /// Its depth.
    #[default]
    Depth,
    /// Its surface-area probability SA(n)/SA(root): the chance a random line through the
    /// root's box passes through it (log scale).
    Area,
    /// Its subtree's share of the tree's SAH cost (log scale).
    Sah,
    /// The triangle references under it (log scale).
    Triangles,
    /// The share of the frame's rays that visited it (measured; log scale): what the
    /// surface-area probability predicts.
    Visits,
}

impl Shade {
    pub const ALL: [Shade; 5] = [
        Shade::Depth,
        Shade::Area,
        Shade::Sah,
        Shade::Triangles,
        Shade::Visits,
    ];

    /// The name on a button.
    pub fn short(self) -> &'static str {
        match self {
            Shade::Depth => "depth",
            Shade::Area => "area",
            Shade::Sah => "SAH share",
            Shade::Triangles => "triangles",
            Shade::Visits => "rays visiting",
        }
    }

    /// The colour bar's name for the quantity.
    pub fn label(self) -> &'static str {
        match self {
            Shade::Depth => "depth",
            Shade::Area => "surface-area probability SA(n)/SA(root)",
            Shade::Sah => "subtree's share of the SAH cost",
            Shade::Triangles => "triangle references under the node",
            Shade::Visits => {
                "share of the frame's rays that visited the node (measured; grey: none did)"
            }
        }
    }

    /// Whether the colour scale is logarithmic.
    pub fn is_log(self) -> bool {
        self != Shade::Depth
    }

    /// Whether it is measured from the frame's rays (and needs their visits).
    pub fn is_measured(self) -> bool {
        self == Shade::Visits
    }
}

impl Width {
    pub const ALL: [Width; 4] = [Width::Triangles, Width::Sah, Width::Uniform, Width::Visits];

    /// The name on a button.
    pub fn short(self) -> &'static str {
        match self {
            Width::Triangles => "triangles",
            Width::Sah => "SAH share",
            Width::Uniform => "equal",
            Width::Visits => "visits",
        }
    }

    pub fn label(self) -> &'static str {
        match self {
            Width::Triangles => "triangles under it",
            Width::Sah => "its subtree's share of the SAH cost",
            Width::Uniform => "an equal share",
            Width::Visits => "its subtree's share of the nodes the frame's rays visited",
        }
    }
}

/// One node's cell: its row (depth) and its span [x0, x1) of the unit width.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cell {
    pub node: u32,
    pub depth: u32,
    pub x0: f64,
    pub x1: f64,
    /// Its subtree is left out: narrower than the fold width, or deeper than the rows.
    pub folded: bool,
    /// The quantity the colour shows (`Shade`).
    pub value: f64,
}

/// The diagram's cells, parents before children, and the range of the shaded quantity.
#[derive(Clone, Debug, PartialEq)]
pub struct Diagram {
    pub cells: Vec<Cell>,
    /// The deepest row drawn.
    pub rows: u32,
    /// The smallest and largest value among the cells (positive values only for a log
    /// scale).
    pub range: (f64, f64),
    /// Nodes of the tree not drawn (under folded cells, or outside a zoomed window).
    pub hidden: usize,
}

/// Per node: triangle references under it, and its subtree's SAH terms
/// Σ SA(m)/SA(root) · C(m) over m in the subtree (C_trav interior, C_isect·N leaf).
/// `accel::triangle_cost` hands the same terms down to the triangles.
pub(crate) struct Subtrees {
    pub(crate) references: Vec<f64>,
    pub(crate) sah: Vec<f64>,
    /// The node's own surface-area probability SA(n)/SA(root) (1 for a flat root).
    pub(crate) area: Vec<f64>,
    nodes: Vec<usize>,
    /// Visits of the subtree's nodes by the frame's rays (zero when none were counted).
    visits: Vec<f64>,
}

/// Visits per outline node by a frame's rays, and how many rays there were.
#[derive(Clone, Copy, Debug)]
pub struct Visits<'a> {
    pub per_node: &'a [u64],
    pub rays: u64,
}

impl Subtrees {
    pub(crate) fn of(
        outline: &Outline,
        c_trav: f32,
        c_isect: f32,
        visits: Option<Visits>,
    ) -> Subtrees {
        let n = outline.nodes.len();
        let root_area = outline
            .nodes
            .first()
            .map_or(0.0, |r| f64::from(r.bounds.surface_area()));
        let mut s = Subtrees {
            references: vec![0.0; n],
            sah: vec![0.0; n],
            area: vec![1.0; n],
            nodes: vec![1; n],
            visits: vec![0.0; n],
        };
        let own_visits = |i: usize| {
            visits
                .and_then(|v| v.per_node.get(i))
                .map_or(0.0, |&v| v as f64)
        };
        // Children come after their parent: one backward pass sums every subtree.
        for i in (0..n).rev() {
            let node = &outline.nodes[i];
            let area = if root_area > 0.0 {
                f64::from(node.bounds.surface_area()) / root_area
            } else {
                1.0
            };
            s.area[i] = area;
            s.visits[i] = own_visits(i);
            if node.is_leaf() {
                s.references[i] = f64::from(node.refs.1);
                s.sah[i] = area * f64::from(c_isect) * f64::from(node.refs.1);
            } else {
                s.sah[i] = area * f64::from(c_trav);
                for c in node.children() {
                    s.references[i] += s.references[c];
                    s.sah[i] += s.sah[c];
                    s.nodes[i] += s.nodes[c];
                    s.visits[i] += s.visits[c];
                }
            }
        }
        s
    }
}

/// How a layout fits its drawing: subtrees narrower than `fold` (a fraction of the window's
/// width) or below row `max_rows` fold, and only the cells within `window`, a span of the
/// unit width the whole tree takes, are laid out (a zoomed diagram).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fit {
    pub fold: f64,
    pub max_rows: u32,
    pub window: (f64, f64),
}

impl Fit {
    /// The whole tree, folding as `fold` and `max_rows` say.
    pub fn whole(fold: f64, max_rows: u32) -> Fit {
        Fit {
            fold,
            max_rows,
            window: (0.0, 1.0),
        }
    }
}

/// What every layout of one tree reads, made once per tree, costs and visits: its subtrees'
/// sums and its nodes' own measured visits.
pub struct Sizes {
    sub: Subtrees,
    own_visits: Vec<f64>,
    rays: u64,
}

impl Sizes {
    /// C_trav and C_isect weigh the SAH shares; `visits` are the frame's rays' visits per
    /// node, for the measured width and shade (without them those read zero).
    pub fn of(outline: &Outline, (c_trav, c_isect): (f32, f32), visits: Option<Visits>) -> Sizes {
        Sizes {
            sub: Subtrees::of(outline, c_trav, c_isect, visits),
            own_visits: (0..outline.nodes.len())
                .map(|i| {
                    visits
                        .and_then(|v| v.per_node.get(i))
                        .map_or(0.0, |&n| n as f64)
                })
                .collect(),
            rays: visits.map_or(0, |v| v.rays),
        }
    }

    /// Lays out `outline` (the tree these sizes are of) as an icicle within `fit`: widths
    /// by `width`, colours by `shade`.
    pub fn layout(&self, outline: &Outline, width: Width, shade: Shade, fit: Fit) -> Diagram {
        let mut diagram = Diagram {
            cells: Vec::new(),
            rows: 0,
            range: (f64::INFINITY, 0.0),
            hidden: 0,
        };
        let Some(root) = outline.nodes.first() else {
            return diagram;
        };
        let sub = &self.sub;
        let total_sah = sub.sah[0];
        let root_area = f64::from(root.bounds.surface_area());
        let value = |i: usize, node: &OutlineNode| match shade {
            Shade::Depth => f64::from(node.depth),
            Shade::Area if root_area > 0.0 => f64::from(node.bounds.surface_area()) / root_area,
            Shade::Area => 1.0,
            Shade::Sah if total_sah > 0.0 => sub.sah[i] / total_sah,
            Shade::Sah => 0.0,
            Shade::Triangles => sub.references[i],
            // The node's own visits: the measured chance a ray enters it.
            Shade::Visits if self.rays > 0 => self.own_visits[i] / self.rays as f64,
            Shade::Visits => 0.0,
        };
        let weight = |i: usize| match width {
            Width::Triangles => sub.references[i],
            Width::Sah => sub.sah[i],
            Width::Uniform => 1.0,
            Width::Visits => sub.visits[i],
        };
        let (w0, w1) = fit.window;
        let fold = fit.fold * (w1 - w0);
        let mut stack = vec![(0usize, 0.0f64, 1.0f64)];
        while let Some((i, x0, x1)) = stack.pop() {
            let node = &outline.nodes[i];
            if x1 <= w0 || x0 >= w1 {
                // Outside the window: neither it nor its subtree is drawn.
                diagram.hidden += sub.nodes[i];
                continue;
            }
            let depth = node.depth - root.depth;
            let folded = !node.is_leaf() && (x1 - x0 < fold || depth >= fit.max_rows);
            let v = value(i, node);
            diagram.cells.push(Cell {
                node: i as u32,
                depth,
                x0,
                x1,
                folded,
                value: v,
            });
            diagram.rows = diagram.rows.max(depth);
            if !shade.is_log() || v > 0.0 {
                diagram.range = (diagram.range.0.min(v), diagram.range.1.max(v));
            }
            if folded {
                diagram.hidden += sub.nodes[i] - 1;
                continue;
            }
            let children = node.children();
            let total: f64 = children.clone().map(weight).sum();
            let count = children.len() as f64;
            let mut at = x0;
            // Pushed last to first, so the first child is drawn first.
            let spans: Vec<(usize, f64, f64)> = children
                .map(|c| {
                    let share = if total > 0.0 {
                        weight(c) / total
                    } else {
                        1.0 / count
                    };
                    let end = at + (x1 - x0) * share;
                    let span = (c, at, end);
                    at = end;
                    span
                })
                .collect();
            stack.extend(spans.into_iter().rev());
        }
        if diagram.range.0 > diagram.range.1 {
            diagram.range = (0.0, 0.0);
        }
        // Parents before children, row by row: the order a picture is drawn in.
        diagram.cells.sort_by_key(|c| c.depth);
        diagram
    }
}

/// Lays out the whole of `outline` as an icicle: widths by `width`, colours by `shade`,
/// subtrees narrower than `fold` (a fraction of the whole width) or below row `max_rows`
/// folded. C_trav and C_isect weigh the SAH shares; `visits` are the frame's rays' visits
/// per node, for the measured width and shade (without them those read zero).
pub fn layout(
    outline: &Outline,
    width: Width,
    shade: Shade,
    fold: f64,
    max_rows: u32,
    costs: (f32, f32),
    visits: Option<Visits>,
) -> Diagram {
    Sizes::of(outline, costs, visits).layout(outline, width, shade, Fit::whole(fold, max_rows))
}

/// A measured cell no ray visited: grey, off the colour scale.
pub const UNVISITED: [u8; 4] = [150, 150, 150, 255];

impl Diagram {
    /// A cell's colour: where its value falls on the viridis scale, or grey for a node the
    /// frame's rays never visited.
    pub fn color(&self, shade: Shade, value: f64) -> [u8; 4] {
        if shade.is_measured() && value <= 0.0 {
            return UNVISITED;
        }
        crate::render::colormap::to_rgba8(crate::render::colormap::viridis(
            self.scale(shade, value) as f32,
        ))
    }

    /// Where `value` falls on the colour scale, 0 to 1 (logarithmic for a log shade).
    pub fn scale(&self, shade: Shade, value: f64) -> f64 {
        let (lo, hi) = self.range;
        let t = if shade.is_log() {
            if value <= 0.0 || lo <= 0.0 || hi <= lo {
                return 0.0;
            }
            (value.ln() - lo.ln()) / (hi.ln() - lo.ln())
        } else if hi > lo {
            (value - lo) / (hi - lo)
        } else {
            0.0
        };
        t.clamp(0.0, 1.0)
    }

    /// The cell drawn for `node`, if it is drawn (not under a folded cell).
    pub fn cell_of(&self, node: u32) -> Option<&Cell> {
        self.cells.iter().find(|c| c.node == node)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::bvh::{BuildParams, build};
    use crate::geometry::Triangle;
    use glam::Vec3;

    fn tree(n: usize) -> Outline {
        // A row of small triangles, a few of them large: an uneven tree.
        let tris: Vec<Triangle> = (0..n)
            .map(|i| {
                let x = i as f32;
                let s = if i % 7 == 0 { 3.0 } else { 0.3 };
                Triangle::new(
                    Vec3::new(x, 0.0, 0.0),
                    Vec3::new(x + s, 0.0, 0.0),
                    Vec3::new(x, s, (i % 5) as f32),
                )
            })
            .collect();
        let params = BuildParams {
            max_leaf_size: 2,
            ..Default::default()
        };
        build(&tris, &params).unwrap().0.outline()
    }

    #[test]
    fn children_split_their_parents_span_by_their_weights() {
        let outline = tree(200);
        for width in [Width::Triangles, Width::Sah, Width::Uniform] {
            let d = layout(
                &outline,
                width,
                Shade::Depth,
                0.0,
                u32::MAX,
                (1.0, 1.0),
                None,
            );
            // Nothing folded: every node drawn once, parents before children.
            assert_eq!(d.cells.len(), outline.nodes.len(), "{width:?}");
            assert_eq!(d.hidden, 0);
            assert_eq!(d.rows, outline.max_depth());
            assert!(d.cells.windows(2).all(|w| w[0].depth <= w[1].depth));
            for (i, node) in outline.nodes.iter().enumerate() {
                let parent = d.cell_of(i as u32).unwrap();
                let kids: Vec<&Cell> = node
                    .children()
                    .map(|c| d.cell_of(c as u32).unwrap())
                    .collect();
                if kids.is_empty() {
                    continue;
                }
                assert!((kids[0].x0 - parent.x0).abs() < 1e-12);
                assert!((kids.last().unwrap().x1 - parent.x1).abs() < 1e-12);
                for pair in kids.windows(2) {
                    assert_eq!(pair[0].x1, pair[1].x0);
                }
                if width == Width::Triangles {
                    // Two children: widths in the ratio of their triangles.
                    let count = |c: usize| outline.triangles_under(c).len() as f64;
                    let (a, b) = (node.first_child as usize, node.first_child as usize + 1);
                    let ratio = (kids[0].x1 - kids[0].x0) / (kids[1].x1 - kids[1].x0);
                    if outline.nodes[a].is_leaf() && outline.nodes[b].is_leaf() {
                        let expected =
                            f64::from(outline.nodes[a].refs.1) / f64::from(outline.nodes[b].refs.1);
                        assert!((ratio - expected).abs() < 1e-9);
                    } else {
                        assert!((ratio - count(a) / count(b)).abs() < 1e-9);
                    }
                }
            }
        }
    }

    #[test]
    fn narrow_or_deep_subtrees_fold_and_hide_exactly_their_nodes() {
        let outline = tree(500);
        let d = layout(
            &outline,
            Width::Triangles,
            Shade::Sah,
            0.01,
            4,
            (1.0, 1.0),
            None,
        );
        assert!(d.rows <= 4);
        let subtree = |i: usize| {
            let mut n = 0;
            let mut stack = vec![i];
            while let Some(j) = stack.pop() {
                n += 1;
                stack.extend(outline.nodes[j].children());
            }
            n
        };
        let hidden: usize = d
            .cells
            .iter()
            .filter(|c| c.folded)
            .map(|c| subtree(c.node as usize) - 1)
            .sum();
        assert_eq!(d.hidden, hidden);
        assert_eq!(d.cells.len() + d.hidden, outline.nodes.len());
        for c in &d.cells {
            // A drawn interior node is wide enough and above the last row, or folded.
            let interior = !outline.nodes[c.node as usize].is_leaf();
            let small = c.x1 - c.x0 < 0.01 || c.depth >= 4;
            assert_eq!(c.folded, interior && small, "{c:?}");
        }
        // The root's SAH share is all of it; every share lies in (0, 1].
        assert!((d.cell_of(0).unwrap().value - 1.0).abs() < 1e-12);
        assert!(
            d.cells
                .iter()
                .all(|c| c.value > 0.0 && c.value <= 1.0 + 1e-12)
        );
        assert_eq!(d.scale(Shade::Sah, 1.0), 1.0);
    }

    #[test]
    fn a_window_lays_out_the_cells_it_spans_where_the_whole_tree_puts_them() {
        let outline = tree(400);
        let sizes = Sizes::of(&outline, (1.0, 1.0), None);
        let all = sizes.layout(
            &outline,
            Width::Triangles,
            Shade::Depth,
            Fit::whole(0.0, u32::MAX),
        );
        let window = (0.3, 0.35);
        let fit = Fit {
            fold: 0.0,
            max_rows: u32::MAX,
            window,
        };
        let part = sizes.layout(&outline, Width::Triangles, Shade::Depth, fit);
        let spanning: Vec<&Cell> = all
            .cells
            .iter()
            .filter(|c| c.x1 > window.0 && c.x0 < window.1)
            .collect();
        assert_eq!(part.cells.len(), spanning.len());
        assert!(part.cells.len() < all.cells.len());
        for c in &part.cells {
            assert_eq!(Some(c), all.cell_of(c.node));
        }
        assert_eq!(part.hidden, outline.nodes.len() - part.cells.len());
        // Folding is relative to the window: a fold of a tenth of it keeps cells a
        // hundredth of the tree wide that the whole tree's tenth would fold.
        let folded = |fit: Fit| sizes.layout(&outline, Width::Triangles, Shade::Depth, fit);
        let coarse = folded(Fit::whole(0.1, u32::MAX));
        let zoomed = folded(Fit { fold: 0.1, ..fit });
        let narrow = |d: &Diagram| d.cells.iter().filter(|c| c.x1 - c.x0 < 0.01).count();
        assert_eq!(narrow(&coarse), 0);
        assert!(narrow(&zoomed) > 0);
    }
}
