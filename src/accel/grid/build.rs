//! Grid construction: choose the resolution from λ·N with cubical cells, then list each
//! triangle in the cells it really overlaps (exact triangle–box test, only over the cells its
//! bounding box spans), stored compactly as offsets + ids by a counting sort. Every step
//! runs in parallel: the assignment per block of triangles, the sort per block of cells.

use super::{Grid, GridError, GridParams, MAX_CELLS, MAX_REFERENCES, PAD, SHARED};
use crate::accel::StructureReport;
use crate::accel::report::Detail;
use crate::geometry::overlap::{TriangleRuns, TriangleSat};
use crate::geometry::{Aabb, Triangle};
use glam::DVec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::time::Instant;

/// Triangles per parallel task of the assignment: at most this many, and fewer on small
/// scenes so that every thread gets several tasks.
const CHUNK: usize = 2048;
const MIN_CHUNK: usize = 64;
const CHUNKS_PER_THREAD: usize = 8;

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
        triangles: triangles.par_iter().copied().collect(),
        mailbox: params.mailbox,
    };
    let pad = extent.max_element() * PAD;
    let parts = Parts::new(cells as usize);
    let pairs = match assign(&grid, pad, parts, true) {
        Err(Stop::Suspect) => {
            estimate_references(&grid, pad)?;
            assign(&grid, pad, parts, false)
        }
        done => done,
    }
    .map_err(Stop::error)?;
    let (offsets, ids) = counting_sort(cells as usize, parts, &pairs);
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

/// References a task counts before adding them to the shared total (one atomic add per
/// batch, not per triangle: two threads adding to one counter for every triangle spent a
/// fifth of the assignment waiting on it).
const BATCH: usize = 1 << 12;

/// A bounding box spanning at most this many cells has each cell tested on its own.
const FEW_CELLS: u32 = 8;

/// Parts of the cell array per worker thread: each part is sorted by one task, a few per
/// thread so that parts holding more references than others even out.
const PARTS_PER_THREAD: usize = 4;

/// The cells cut into parts of 2^shift consecutive indices (the last one shorter): the
/// assignment files each (cell, triangle) pair under its cell's part, so each part is
/// counted and sorted on its own, in parallel.
#[derive(Clone, Copy)]
struct Parts {
    shift: u32,
    count: usize,
}

impl Parts {
    fn new(cells: usize) -> Self {
        let want = (rayon::current_num_threads() * PARTS_PER_THREAD).max(1);
        let size = cells.div_ceil(want).max(1).next_power_of_two();
        Parts {
            shift: size.trailing_zeros(),
            count: cells.div_ceil(size).max(1),
        }
    }

    #[inline(always)]
    fn of(self, cell: u32) -> usize {
        (cell >> self.shift) as usize
    }

    /// The cells of part `p`.
    fn range(self, p: usize, cells: usize) -> std::ops::Range<usize> {
        (p << self.shift)..((p + 1) << self.shift).min(cells)
    }
}

/// One task's (cell, triangle) pairs, per part, in triangle order; `SHARED` is set on
/// triangles in several cells.
type Pairs = Vec<Vec<(u32, u32)>>;

/// The (cell, triangle) pair of every cell a triangle overlaps, per task and part; stops
/// past `MAX_REFERENCES`, or (with `guard`) when large triangles span too many cells.
fn assign(grid: &Grid, pad: f64, parts: Parts, guard: bool) -> Result<Vec<Pairs>, Stop> {
    let total = AtomicUsize::new(0);
    let spanned = AtomicU64::new(0);
    let over = AtomicBool::new(false);
    let suspect = AtomicBool::new(false);
    let add = |batch: &mut usize| {
        if *batch > 0 && total.fetch_add(*batch, Ordering::Relaxed) + *batch > MAX_REFERENCES {
            over.store(true, Ordering::Relaxed);
        }
        *batch = 0;
    };
    let size = (grid.triangles.len() / (rayon::current_num_threads() * CHUNKS_PER_THREAD))
        .clamp(MIN_CHUNK, CHUNK);
    let chunks: Vec<Pairs> = grid
        .triangles
        .par_chunks(size)
        .enumerate()
        .map(|(c, chunk)| {
            let mut out: Pairs =
                vec![Vec::with_capacity(chunk.len() * 2 / parts.count); parts.count];
            let mut cells = Vec::new();
            let mut batch = 0;
            for (j, tri) in chunk.iter().enumerate() {
                let id = (c * size + j) as u32;
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
                cells.clear();
                cells_in(grid, tri, pad, l, h, |cell| cells.push(cell));
                let id = if cells.len() > 1 { id | SHARED } else { id };
                for &cell in &cells {
                    out[parts.of(cell)].push((cell, id));
                }
                batch += cells.len();
                if batch >= BATCH {
                    add(&mut batch);
                }
            }
            add(&mut batch);
            out
        })
        .collect();
    if over.into_inner() {
        let references = chunks.iter().flatten().map(Vec::len).sum::<usize>();
        return Err(Stop::Over(references as u64));
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
/// are tested.
#[inline]
fn cells_of(grid: &Grid, tri: &Triangle, pad: f64, f: impl FnMut(u32)) {
    let (l, h) = cell_range(grid, tri, pad);
    cells_in(grid, tri, pad, l, h, f);
}

/// `cells_of` with the range already known. A box of a few cells is tested cell by cell; a
/// larger one is walked in rows along its longest axis `u`: the overlapping cells of a row
/// are one run (see `TriangleRuns`), found from the separating axes once per row rather
/// than once per cell.
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
    let center = |k: usize, i: u32| grid.origin[k] + (f64::from(i) + 0.5) * grid.cell[k];
    let volume: u32 = (0..3).map(|k| h[k] - l[k] + 1).product();
    if volume <= FEW_CELLS {
        // A box of a few cells: testing each costs less than preparing the rows.
        let slabs = TriangleSat::new(tri).slabs(grid.cell * 0.5 + pad);
        for z in l[2]..=h[2] {
            for y in l[1]..=h[1] {
                for x in l[0]..=h[0] {
                    let c = DVec3::new(center(0, x), center(1, y), center(2, z));
                    if slabs.overlaps_centered(c) {
                        f(grid.linear([x, y, z]) as u32);
                    }
                }
            }
        }
        return;
    }
    let u = (0..3).max_by_key(|&k| h[k] - l[k]).unwrap_or(0);
    let (v, w) = ((u + 1) % 3, (u + 2) % 3);
    let runs = TriangleRuns::new(&TriangleSat::new(tri), grid.cell * 0.5 + pad, u);
    let stride = [1, grid.res[0], grid.res[0] * grid.res[1]];
    // Cell i's centre on u is origin + (i + ½)·cell; the run's bounds become the first and
    // last such i. Clamped to [l − 1, h + 1] first (an infinite bound too) and moved up by
    // one, the values are small and non-negative, where truncation is the floor.
    let (lu, hu) = (f64::from(l[u]), f64::from(h[u]));
    let shifted = |t: f64| {
        let x = (t - grid.origin[u]) * grid.inv_cell[u] + 0.5;
        x.max(lu).min(hu + 2.0)
    };
    let mut c = DVec3::ZERO;
    for j in l[w]..=h[w] {
        c[w] = center(w, j);
        for i in l[v]..=h[v] {
            c[v] = center(v, i);
            let (t0, t1) = runs.run(c);
            if t0 > t1 {
                continue;
            }
            let (a, b) = (shifted(t0), shifted(t1));
            // ceil(a) − 1 and floor(b) − 1, within the box.
            let first = (a as u32 + u32::from(f64::from(a as u32) < a)).max(l[u] + 1) - 1;
            let last = (b as u32).min(h[u] + 1);
            if first >= last {
                continue;
            }
            let last = last - 1;
            let row = i * stride[v] + j * stride[w];
            for k in first..=last {
                f(row + k * stride[u]);
            }
        }
    }
}

/// Offsets (cells + 1) and ids, each cell's ids in increasing triangle order: a counting
/// sort per part, in parallel (each part's pairs are already in triangle order).
fn counting_sort(cells: usize, parts: Parts, chunks: &[Pairs]) -> (Vec<u32>, Vec<u32>) {
    // Per part: each cell's first slot within the part, and the part's total.
    let starts: Vec<(Vec<u32>, u32)> = (0..parts.count)
        .into_par_iter()
        .map(|p| {
            let range = parts.range(p, cells);
            let mut start = vec![0u32; range.len()];
            for chunk in chunks {
                for &(c, _) in &chunk[p] {
                    start[c as usize - range.start] += 1;
                }
            }
            let mut sum = 0;
            for s in &mut start {
                (*s, sum) = (sum, sum + *s);
            }
            (start, sum)
        })
        .collect();
    let total: usize = starts.iter().map(|&(_, n)| n as usize).sum();
    let mut offsets = vec![0u32; cells + 1];
    let mut ids = vec![0u32; total];
    // Disjoint slices of offsets and ids for each part.
    let mut tasks = Vec::with_capacity(parts.count);
    let (mut offsets_rest, mut ids_rest) = (&mut offsets[..cells], &mut ids[..]);
    let mut base = 0u32;
    for (p, (start, n)) in starts.into_iter().enumerate() {
        let (o, orest) = offsets_rest.split_at_mut(parts.range(p, cells).len());
        let (i, irest) = ids_rest.split_at_mut(n as usize);
        (offsets_rest, ids_rest) = (orest, irest);
        tasks.push((p, start, base, o, i));
        base += n;
    }
    tasks
        .into_par_iter()
        .for_each(|(p, mut cursor, base, offsets, ids)| {
            let first = parts.range(p, cells).start;
            for (o, &s) in offsets.iter_mut().zip(&cursor) {
                *o = base + s;
            }
            for chunk in chunks {
                for &(c, t) in &chunk[p] {
                    let slot = &mut cursor[c as usize - first];
                    ids[*slot as usize] = t;
                    *slot += 1;
                }
            }
        });
    offsets[cells] = total as u32;
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
            ("resolution".into(), format!("{nx} × {ny} × {nz}").into()),
            (
                "λ (cells per triangle)".into(),
                format!("{}", params.lambda).into(),
            ),
            ("cells".into(), Detail::count(cells)),
            (
                "cells per triangle".into(),
                Detail::Number(cells as f64 / grid.triangles.len().max(1) as f64, 2),
            ),
        ],
        caps_hit: Vec::new(),
    }
}
