//! The median splits: cheap to build and balanced, but blind to where the rays go.

use super::prim::{NodeInfo, PrimRef, Split, partition, split_at};

/// Equal counts on both sides: the median centroid along the widest centroid axis.
pub fn object_median(refs: &mut [PrimRef], info: &NodeInfo) -> Split {
    let (axis, _) = info.centroid_axis();
    let m = refs.len() / 2;
    refs.select_nth_unstable_by(m, |a, b| {
        a.centroid2()[axis].total_cmp(&b.centroid2()[axis])
    });
    split_at(refs, m)
}

/// Split at the midpoint of the centroid bounds along their widest axis. When rounding puts
/// every centroid on one side, fall back to the object median so the split always makes
/// progress.
pub fn spatial_median(refs: &mut [PrimRef], info: &NodeInfo) -> Split {
    let c = &info.centroids;
    let (axis, _) = info.centroid_axis();
    let mid = 0.5 * (c.min[axis] + c.max[axis]);
    let split = partition(refs, |r| r.centroid2()[axis] < mid);
    if split.0 == 0 || split.0 == refs.len() {
        object_median(refs, info)
    } else {
        split
    }
}
