//! Grid construction: choose the resolution from λ·N with cubical cells, then list each
//! triangle in the cells it really overlaps (exact triangle–box test, only over the cells its
//! bounding box spans), stored compactly as offsets + ids by a counting sort.

use super::{Grid, GridError, GridParams, MAX_CELLS, MAX_REFERENCES, PAD, SHARED};
use crate::accel::StructureReport;
use crate::geometry::overlap::TriangleSat;
use crate::geometry::{Aabb, Triangle};
use glam::DVec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::time::Instant;

/// Triangles per parallel task of the assignment.
const CHUNK: usize = 2048;

/// Triangles whose overlaps are counted to estimate the references of a suspect scene.
const SAMPLES: usize = 32;

pub fn build(
    triangles: &[Triangle],
    params: &GridParams,
) -> Result<(Grid, StructureReport), GridError> {
    params.validate()?;
    if triangles.len() >= (u32::MAX / 2) as usize {
        return Err(GridError::TooMany(triangles.len()));
    }
    if let Some(i) = triangles.par_iter().position_any(|t| !t.is_finite()) {
        return Err(GridError::NonFinite(i));
    }
    let start = Instant::now();
    let bounds = triangles
        .par_iter()
        .map(|t| t.bounds())
        .reduce(|| Aabb::EMPTY, Aabb::union);
    let res = resolution(&bounds, triangles.len(), params.lambda);
    let cells = res[0].saturating_mul(res[1]).saturating_mul(res[2]);
    if cells > MAX_CELLS as u64 {
        return Err(GridError::TooManyCells {
            nx: res[0],
            ny: res[1],
            nz: res[2],
            cells,
            lambda: params.lambda,
            triangles: triangles.len(),
        });
    }
    let res = res.map(|n| n as u32);
    let (origin, extent) = if bounds.is_empty() {
        (DVec3::ZERO, DVec3::ZERO)
    } else {
        (bounds.min.as_dvec3(), bounds.extent().as_dvec3())
    };
    let cell = extent / DVec3::new(res[0].into(), res[1].into(), res[2].into());
    let inv_cell = cell.map(|c| if c > 0.0 { 1.0 / c } else { 0.0 });
    let mut grid = Grid {
        bounds,
        origin,
        cell,
        inv_cell,
        res,
        offsets: Vec::new(),
        ids: Vec::new(),
        triangles: triangles.to_vec(),
        mailbox: params.mailbox,
    };
    let pad = extent.max_element() * PAD;
    let pairs = match assign(&grid, pad, true) {
        Err(Stop::Suspect) => {
            estimate_references(&grid, pad)?;
            assign(&grid, pad, false)
        }
        done => done,
    }
    .map_err(Stop::error)?;
    let (offsets, ids) = counting_sort(cells as usize, &pairs);
    drop(pairs);
    grid.offsets = offsets;
    grid.ids = ids;
    let build_time = start.elapsed();
    let report = report(&grid, params, build_time);
    Ok((grid, report))
}

/// Cells per axis: λ·N cells in all, as cubical as the bounds allow. A flat axis, or one
/// thinner than a cell would be, gets a single cell and the others share the count.
fn resolution(bounds: &Aabb, n: usize, lambda: f32) -> [u64; 3] {
    let mut res = [1u64; 3];
    if n == 0 || bounds.is_empty() {
        return res;
    }
    let e = bounds.extent().as_dvec3();
    let target = (f64::from(lambda) * n as f64).max(1.0);
    let mut active: Vec<usize> = (0..3).filter(|&k| e[k] > 0.0).collect();
    // The side s of a cubical cell giving `target` cells over the active axes; axes
    // thinner than s get one cell (which does not change the target) and s is recomputed.
    let mut side = 0.0;
    while !active.is_empty() {
        let volume: f64 = active.iter().map(|&k| e[k]).product();
        side = (volume / target).powf(1.0 / active.len() as f64);
        let before = active.len();
        active.retain(|&k| e[k] >= side);
        if active.len() == before {
            break;
        }
    }
    for &k in &active {
        // Saturating: an absurd count is caught by the caller's MAX_CELLS check.
        res[k] = ((e[k] / side).round() as u64).max(1);
    }
    res
}

/// Fails if the triangles would be listed more than `MAX_REFERENCES` times, judged from
/// the real overlaps of a few evenly spaced triangles. Called only when the assignment met
/// triangles spanning so many cells that it could run long before the real count passes
/// the limit (triangles far larger than the cells, such as one triangle copied 10^7 times).
fn estimate_references(grid: &Grid, pad: f64) -> Result<(), GridError> {
    let n = grid.triangles.len();
    let samples = n.min(SAMPLES);
    let counted: usize = (0..samples)
        .into_par_iter()
        .map(|s| {
            let mut c = 0;
            cells_of(grid, &grid.triangles[s * n / samples], pad, |_| c += 1);
            c
        })
        .sum();
    let estimate = counted as f64 * n as f64 / samples as f64;
    if estimate > MAX_REFERENCES as f64 {
        return Err(GridError::TooManyReferences {
            references: estimate as u64,
            estimated: true,
        });
    }
    Ok(())
}

/// Why the assignment stopped.
enum Stop {
    /// More than `MAX_REFERENCES` references (this many so far).
    Over(u64),
    /// Large triangles spanned so many cells that it stopped to estimate the references.
    Suspect,
}

impl Stop {
    fn error(self) -> GridError {
        match self {
            Stop::Over(references) => GridError::TooManyReferences {
                references,
                estimated: false,
            },
            Stop::Suspect => GridError::TooManyReferences {
                references: MAX_REFERENCES as u64,
                estimated: true,
            },
        }
    }
}

/// A triangle whose bounding box spans more cells than this is large: the cells all large
/// triangles span are summed, and past `MAX_REFERENCES` the assignment stops to estimate.
const LARGE: u64 = 1 << 12;

/// (cell, triangle) for every cell a triangle overlaps, in triangle order, per chunk, with
/// `SHARED` set on triangles in several cells; stops
/// past `MAX_REFERENCES`, or (with `guard`) when large triangles span too many cells.
fn assign(grid: &Grid, pad: f64, guard: bool) -> Result<Vec<Vec<(u32, u32)>>, Stop> {
    let total = AtomicUsize::new(0);
    let spanned = AtomicU64::new(0);
    let over = AtomicBool::new(false);
    let suspect = AtomicBool::new(false);
    let chunks: Vec<Vec<(u32, u32)>> = grid
        .triangles
        .par_chunks(CHUNK)
        .enumerate()
        .map(|(c, chunk)| {
            let mut out = Vec::with_capacity(chunk.len() * 2);
            for (j, tri) in chunk.iter().enumerate() {
                let id = (c * CHUNK + j) as u32;
                let (l, h) = cell_range(grid, tri, pad);
                let volume: u64 = (0..3).map(|k| u64::from(h[k] - l[k] + 1)).product();
                if guard
                    && volume > LARGE
                    && spanned.fetch_add(volume, Ordering::Relaxed) + volume > MAX_REFERENCES as u64
                {
                    suspect.store(true, Ordering::Relaxed);
                }
                if (j % 64 == 0 || volume > LARGE)
                    && (over.load(Ordering::Relaxed) || suspect.load(Ordering::Relaxed))
                {
                    break;
                }
                let before = out.len();
                cells_in(grid, tri, pad, l, h, |cell| out.push((cell, id)));
                let added = out.len() - before;
                if added > 1 {
                    for pair in &mut out[before..] {
                        pair.1 |= SHARED;
                    }
                    if total.fetch_add(added, Ordering::Relaxed) + added > MAX_REFERENCES {
                        over.store(true, Ordering::Relaxed);
                    }
                }
            }
            out
        })
        .collect();
    if over.into_inner() {
        return Err(Stop::Over(chunks.iter().map(Vec::len).sum::<usize>() as u64));
    }
    if suspect.into_inner() {
        return Err(Stop::Suspect);
    }
    Ok(chunks)
}

/// The range of cells the bounding box of `tri`, enlarged by `pad`, spans.
#[inline]
fn cell_range(grid: &Grid, tri: &Triangle, pad: f64) -> ([u32; 3], [u32; 3]) {
    let b = tri.bounds();
    let (lo, hi) = (b.min.as_dvec3() - pad, b.max.as_dvec3() + pad);
    (
        [0, 1, 2].map(|k| grid.cell_of(k, lo[k])),
        [0, 1, 2].map(|k| grid.cell_of(k, hi[k])),
    )
}

/// Calls `f` with each cell `tri` overlaps (cells enlarged by `pad`). A triangle whose
/// enlarged bounding box spans one cell, or a run of cells along one axis, overlaps them all
/// (it is connected and spans the run), so only boxes spanning cells on two or more axes
/// are tested cell by cell.
#[inline]
fn cells_of(grid: &Grid, tri: &Triangle, pad: f64, f: impl FnMut(u32)) {
    let (l, h) = cell_range(grid, tri, pad);
    cells_in(grid, tri, pad, l, h, f);
}

/// `cells_of` with the range already known.
#[inline]
fn cells_in(
    grid: &Grid,
    tri: &Triangle,
    pad: f64,
    l: [u32; 3],
    h: [u32; 3],
    mut f: impl FnMut(u32),
) {
    let spans = (0..3).filter(|&k| h[k] > l[k]).count();
    if spans <= 1 {
        for z in l[2]..=h[2] {
            for y in l[1]..=h[1] {
                for x in l[0]..=h[0] {
                    f(grid.linear([x, y, z]) as u32);
                }
            }
        }
        return;
    }
    let slabs = TriangleSat::new(tri).slabs(grid.cell * 0.5 + pad);
    let center = |k: usize, i: u32| grid.origin[k] + (f64::from(i) + 0.5) * grid.cell[k];
    for z in l[2]..=h[2] {
        let cz = center(2, z);
        for y in l[1]..=h[1] {
            let cy = center(1, y);
            for x in l[0]..=h[0] {
                if slabs.overlaps_centered(DVec3::new(center(0, x), cy, cz)) {
                    f(grid.linear([x, y, z]) as u32);
                }
            }
        }
    }
}

/// Offsets (cells + 1) and ids, each cell's ids in increasing triangle order.
fn counting_sort(cells: usize, chunks: &[Vec<(u32, u32)>]) -> (Vec<u32>, Vec<u32>) {
    let mut offsets = vec![0u32; cells + 1];
    for chunk in chunks {
        for &(c, _) in chunk {
            offsets[c as usize + 1] += 1;
        }
    }
    for c in 0..cells {
        offsets[c + 1] += offsets[c];
    }
    let mut cursor = offsets.clone();
    let mut ids = vec![0u32; offsets[cells] as usize];
    for chunk in chunks {
        for &(c, t) in chunk {
            let slot = &mut cursor[c as usize];
            ids[*slot as usize] = t;
            *slot += 1;
        }
    }
    (offsets, ids)
}

fn report(grid: &Grid, params: &GridParams, build_time: std::time::Duration) -> StructureReport {
    let cells = grid.cells();
    let counts = grid.offsets.windows(2).map(|w| (w[1] - w[0]) as usize);
    let empty = counts.clone().filter(|&c| c == 0).count();
    let largest = counts.max().unwrap_or(0);
    let [nx, ny, nz] = grid.res;
    StructureReport {
        structure: "grid",
        triangles: grid.triangles.len(),
        build_time,
        bytes: grid.bytes(),
        nodes: cells,
        leaves: cells,
        empty_leaves: empty,
        max_depth: 0,
        references: grid.ids.len(),
        largest_leaf: largest,
        details: vec![
            ("resolution".into(), format!("{nx} × {ny} × {nz}")),
            (
                "λ (cells per triangle)".into(),
                format!("{}", params.lambda),
            ),
            ("cells".into(), cells.to_string()),
            (
                "cells per triangle".into(),
                format!("{:.2}", cells as f64 / grid.triangles.len().max(1) as f64),
            ),
        ],
        caps_hit: Vec::new(),
    }
}
