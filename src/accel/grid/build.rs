//! Grid construction: choose the resolution from λ·N with cubical cells, then list each
//! triangle in the cells it really overlaps (exact triangle–box test, only over the cells its
//! bounding box spans), stored compactly as offsets + ids by a counting sort.

use super::{Grid, GridError, GridParams, MAX_CELLS, MAX_REFERENCES, PAD};
use crate::accel::StructureReport;
use crate::geometry::overlap::TriangleSat;
use crate::geometry::{Aabb, Triangle};
use glam::DVec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::Instant;

/// Triangles per parallel task of the assignment.
const CHUNK: usize = 8192;

/// Triangles whose overlaps are counted to estimate the references of a suspect scene.
const SAMPLES: usize = 32;

pub fn build(
    triangles: &[Triangle],
    params: &GridParams,
) -> Result<(Grid, StructureReport), GridError> {
    params.validate()?;
    if triangles.len() >= u32::MAX as usize {
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
    check_references(&grid, pad)?;
    let pairs = assign(&grid, pad)?;
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

/// Fails if the triangles would be listed more than `MAX_REFERENCES` times, before any
/// list is stored. Summing the cells each bounding box spans bounds the count from above at
/// no cost; only when that bound is too high are the real overlaps of a few evenly spaced
/// triangles counted and the total extrapolated from them (triangles far larger than the
/// cells, such as one triangle copied 10^7 times, are refused in well under a second). The
/// assignment itself stops too if the real count passes the limit.
fn check_references(grid: &Grid, pad: f64) -> Result<(), GridError> {
    let n = grid.triangles.len();
    let bound: u64 = grid
        .triangles
        .par_iter()
        .map(|tri| {
            let (l, h) = cell_range(grid, tri, pad);
            (0..3).map(|k| u64::from(h[k] - l[k] + 1)).product::<u64>()
        })
        .sum();
    if bound <= MAX_REFERENCES as u64 {
        return Ok(());
    }
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

/// (cell, triangle) for every cell a triangle overlaps, in triangle order, per chunk.
fn assign(grid: &Grid, pad: f64) -> Result<Vec<Vec<(u32, u32)>>, GridError> {
    let total = AtomicUsize::new(0);
    let over = AtomicBool::new(false);
    let chunks: Vec<Vec<(u32, u32)>> = grid
        .triangles
        .par_chunks(CHUNK)
        .enumerate()
        .map(|(c, chunk)| {
            let mut out = Vec::with_capacity(chunk.len() * 2);
            for (j, tri) in chunk.iter().enumerate() {
                let id = (c * CHUNK + j) as u32;
                let before = out.len();
                cells_of(grid, tri, pad, |cell| out.push((cell, id)));
                let added = out.len() - before;
                if added > 1 && total.fetch_add(added, Ordering::Relaxed) + added > MAX_REFERENCES {
                    over.store(true, Ordering::Relaxed);
                }
                if j % 64 == 0 && over.load(Ordering::Relaxed) {
                    break;
                }
            }
            out
        })
        .collect();
    let total: usize = chunks.iter().map(Vec::len).sum();
    if over.into_inner() || total > MAX_REFERENCES {
        return Err(GridError::TooManyReferences {
            references: total as u64,
            estimated: false,
        });
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

/// Calls `f` with each cell `tri` overlaps (cells enlarged by `pad`).
#[inline]
fn cells_of(grid: &Grid, tri: &Triangle, pad: f64, mut f: impl FnMut(u32)) {
    let (l, h) = cell_range(grid, tri, pad);
    if l == h {
        f(grid.linear(l) as u32);
        return;
    }
    let sat = TriangleSat::new(tri);
    for z in l[2]..=h[2] {
        for y in l[1]..=h[1] {
            for x in l[0]..=h[0] {
                let i = [x, y, z];
                let min = DVec3::new(grid.plane(0, x), grid.plane(1, y), grid.plane(2, z)) - pad;
                let max = DVec3::new(
                    grid.plane(0, x + 1),
                    grid.plane(1, y + 1),
                    grid.plane(2, z + 1),
                ) + pad;
                if sat.overlaps(min, max) {
                    f(grid.linear(i) as u32);
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
