//! `bvhlab frames`: the explorer's frames timed as the app makes them, through its worker
//! (`frames.rs`: a view's preview, full and drag frames; `lecture.rs`: each built-in
//! lecture step's first image and full frame).

pub mod frames;
pub mod lecture;
