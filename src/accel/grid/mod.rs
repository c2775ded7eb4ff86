//! The uniform grid: the scene's box cut into about λ·N equal, nearly cubical cells, each
//! listing the triangles that really overlap it, walked by a ray cell by cell with the 3D-DDA
//! of Amanatides and Woo (3D line rasterisation). Cheap to build and fast where triangles are
//! spread evenly (grass); the lecture's "teapot in a stadium" is where it fails.

mod build;
pub(crate) mod dda;

pub use build::build;

use super::{Outline, OutlineNode};
use crate::geometry::{Aabb, Triangle};
use glam::DVec3;
use thiserror::Error;

/// The most cells a grid may have (64 Mi: 256 MiB of cell offsets); a resolution above it
/// is an error, and nothing is built.
pub const MAX_CELLS: usize = 1 << 26;

/// The most triangle references (triangle ids over all cells) a grid may hold (128 Mi:
/// 512 MiB of ids); triangles far larger than the cells exceed it, and nothing is built.
pub const MAX_REFERENCES: usize = 1 << 27;

/// The valid range of λ, the number of cells per triangle.
pub const LAMBDA_RANGE: std::ops::RangeInclusive<f32> = 1.0 / 16.0..=64.0;

/// Cells are enlarged by this fraction of the grid's largest extent when triangles are
/// assigned, so a triangle within rounding of a cell's boundary is listed in both cells:
/// the ray–triangle test may accept a hit a few ulps outside the triangle, and that hit's
/// cell must still list it.
pub(crate) const PAD: f64 = 1.0 / (1u64 << 18) as f64;

pub(crate) use crate::accel::mailbox::{SHARED, mark_shared};

#[derive(
    Clone,
    Copy,
    Debug,
    PartialEq,
    serde::Serialize,
    serde::Deserialize,
    clap::Args,
    bvhlab_derive::Controls,
)]
#[serde(default)]
pub struct GridParams {
    /// Uniform grid: cells ≈ λ · triangles (1/16..=64).
    #[serde(rename = "grid_lambda")]
    #[arg(id = "grid_lambda", long = "lambda", value_name = "LAMBDA", default_value_t = GridParams::default().lambda)]
    #[param(label = "λ (cells ≈ λ·N)", range = *LAMBDA_RANGE.start()..=*LAMBDA_RANGE.end(), log)]
    pub lambda: f32,
    /// Skip triangles the ray has tested already (they are listed in every cell they
    /// overlap); the grid's `mailbox` field switches it without a rebuild.
    #[serde(skip)]
    #[arg(skip = true)]
    pub mailbox: bool,
}

impl Default for GridParams {
    fn default() -> Self {
        GridParams {
            lambda: 1.0,
            mailbox: true,
        }
    }
}

impl GridParams {
    pub fn validate(&self) -> Result<(), GridError> {
        if LAMBDA_RANGE.contains(&self.lambda) {
            Ok(())
        } else {
            Err(GridError::Lambda(self.lambda))
        }
    }
}

#[derive(Clone, Debug, Error, PartialEq)]
pub enum GridError {
    #[error("λ = {0} is outside 1/16..=64 (cells ≈ λ · triangles)")]
    Lambda(f32),
    #[error(
        "{nx} × {ny} × {nz} = {cells} cells (λ = {lambda}, {triangles} triangles) is more \
         than the {MAX_CELLS} a grid may have; lower λ"
    )]
    TooManyCells {
        nx: u64,
        ny: u64,
        nz: u64,
        cells: u64,
        lambda: f32,
        triangles: usize,
    },
    #[error(
        "the triangles would be listed in {references}{} cells in all, more than the \
         {MAX_REFERENCES} a grid may hold: they are far larger than the cells; lower λ",
        if *estimated { " (estimated)" } else { " or more" }
    )]
    TooManyReferences { references: u64, estimated: bool },
    #[error("triangle {0} has a NaN or infinite vertex")]
    NonFinite(usize),
    #[error("{0} triangles is more than a grid with 31-bit indices can hold")]
    TooMany(usize),
}

/// A uniform grid over a copy of the scene's triangles.
#[derive(Clone, Debug)]
pub struct Grid {
    /// The grid's box: the scene's bounds.
    pub(crate) bounds: Aabb,
    /// The box's minimum corner and the cell size per axis, in f64 (size 0 on a flat axis).
    pub(crate) origin: DVec3,
    pub(crate) cell: DVec3,
    /// 1 / cell size, 0 on a flat axis (so every point maps to cell 0 there).
    pub(crate) inv_cell: DVec3,
    pub(crate) res: [u32; 3],
    /// Cell c lists `ids[offsets[c]..offsets[c + 1]]` (with `SHARED` set on triangles
    /// listed in several cells); cells in x-fastest order.
    pub(crate) offsets: Vec<u32>,
    pub(crate) ids: Vec<u32>,
    pub(crate) triangles: Vec<Triangle>,
    /// Skip triangles the ray has tested already.
    pub mailbox: bool,
}

impl Grid {
    /// Cells per axis.
    pub fn resolution(&self) -> [u32; 3] {
        self.res
    }

    pub fn cells(&self) -> usize {
        self.res.iter().map(|&n| n as usize).product()
    }

    /// Memory of the grid, triangles included.
    pub fn bytes(&self) -> usize {
        std::mem::size_of::<Grid>()
            + 4 * (self.offsets.len() + self.ids.len())
            + std::mem::size_of::<Triangle>() * self.triangles.len()
    }

    /// The triangles listed in cell `c` (x-fastest index).
    pub fn cell_triangles(&self, c: usize) -> Vec<u32> {
        self.ids[self.offsets[c] as usize..self.offsets[c + 1] as usize]
            .iter()
            .map(|&id| id & !SHARED)
            .collect()
    }

    /// The x-fastest index of cell (x, y, z).
    #[inline(always)]
    pub(crate) fn linear(&self, i: [u32; 3]) -> usize {
        i[0] as usize
            + self.res[0] as usize * (i[1] as usize + self.res[1] as usize * i[2] as usize)
    }

    /// The plane between cells i − 1 and i on `axis`.
    #[inline(always)]
    pub(crate) fn plane(&self, axis: usize, i: u32) -> f64 {
        self.origin[axis] + f64::from(i) * self.cell[axis]
    }

    /// The cell holding coordinate `x` on `axis`, clamped to the grid.
    #[inline(always)]
    pub(crate) fn cell_of(&self, axis: usize, x: f64) -> u32 {
        // Truncation is the floor once negatives are clamped to 0 (and `max` turns NaN into
        // 0); `as` saturates, and the `min` keeps the index inside.
        let f = ((x - self.origin[axis]) * self.inv_cell[axis]).max(0.0);
        (f as u64).min(u64::from(self.res[axis] - 1)) as u32
    }

    /// The box of cell (x, y, z).
    pub fn cell_bounds(&self, i: [u32; 3]) -> Aabb {
        let lo = DVec3::new(
            self.plane(0, i[0]),
            self.plane(1, i[1]),
            self.plane(2, i[2]),
        );
        let hi = DVec3::new(
            self.plane(0, i[0] + 1),
            self.plane(1, i[1] + 1),
            self.plane(2, i[2] + 1),
        );
        Aabb::new(lo.as_vec3(), hi.as_vec3())
    }

    fn cell_index3(&self, c: usize) -> [u32; 3] {
        let (nx, ny) = (self.res[0] as usize, self.res[1] as usize);
        [
            (c % nx) as u32,
            ((c / nx) % ny) as u32,
            (c / (nx * ny)) as u32,
        ]
    }

    /// What the app draws: the grid's box as the root and the occupied cells as its
    /// children (depth 1), each with its triangles.
    pub fn outline(&self) -> Outline {
        let occupied: Vec<usize> = (0..self.cells())
            .filter(|&c| self.offsets[c] != self.offsets[c + 1])
            .collect();
        let mut nodes = Vec::with_capacity(occupied.len() + 1);
        nodes.push(OutlineNode {
            bounds: self.bounds,
            depth: 0,
            parent: u32::MAX,
            first_child: if occupied.is_empty() { 0 } else { 1 },
            child_count: occupied.len() as u32,
            refs: (0, 0),
            plane: None,
        });
        nodes.extend(occupied.iter().map(|&c| OutlineNode {
            bounds: self.cell_bounds(self.cell_index3(c)),
            depth: 1,
            parent: 0,
            first_child: 0,
            child_count: 0,
            refs: (self.offsets[c], self.offsets[c + 1] - self.offsets[c]),
            plane: None,
        }));
        Outline {
            nodes,
            refs: self.ids.iter().map(|&id| id & !SHARED).collect(),
        }
    }
}
