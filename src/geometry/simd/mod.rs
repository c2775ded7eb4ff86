//! SIMD kernels: one slab test over the W child boxes of a wide BVH node at once, one slab
//! test of one box against a packet of rays at once, and one watertight triangle test over a
//! wide leaf's block of four triangles.
//!
//! Each kernel is written with `std::arch` for one instruction set and chosen at run time
//! (`SimdLevel::detect`), with a portable path that gives identical answers on any machine.
//! They compute exactly what the scalar `slab_entry` and `Watertight` compute, lane by lane and
//! in the same order of operations, so a wide BVH's hits equal the BVH2's bit for bit.

pub mod interval;
pub mod packet;
pub mod packet_triangle;
pub mod ray_packet;
pub mod slab;
pub mod triangle;

pub use interval::{IntervalSlab, WideInterval};
pub use packet::PacketSlab;
pub use packet_triangle::{PacketBest, PacketHits, PacketShear, PacketTriangleKernel};
pub use ray_packet::{PACKET_RAYS, RayLoad, RayPacket, prefetch_packet};
pub use slab::{WideRay, WideSlab};
pub use triangle::{BLOCK, BlockHits, TriangleBlock, TriangleKernel};

/// The instruction set of a kernel type, known when the traversal is compiled: a traversal
/// generic over its kernel calls the out-of-line parts compiled for the same set.
pub trait KernelLevel {
    const LEVEL: SimdLevel;
}

impl KernelLevel for slab::Portable {
    const LEVEL: SimdLevel = SimdLevel::Portable;
}
impl KernelLevel for slab::Sse41 {
    const LEVEL: SimdLevel = SimdLevel::Sse41;
}
impl KernelLevel for slab::Avx2 {
    const LEVEL: SimdLevel = SimdLevel::Avx2;
}
impl KernelLevel for slab::Avx512 {
    const LEVEL: SimdLevel = SimdLevel::Avx512;
}

/// Asks for the cache line holding `p` ahead of its use, so that loading a child's box rows
/// or a leaf's triangles overlaps the work on its siblings. A hint: it never faults, and does
/// nothing where there is no prefetch instruction.
#[inline(always)]
pub fn prefetch<T>(p: *const T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch reads nothing and never faults, whatever the address; SSE is part
    // of every x86-64 CPU.
    unsafe {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        _mm_prefetch::<_MM_HINT_T0>(p.cast());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}

/// The instruction set a kernel is written for.
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    Eq,
    Hash,
    PartialOrd,
    Ord,
    serde::Serialize,
    serde::Deserialize,
    clap::ValueEnum,
)]
pub enum SimdLevel {
    /// Plain Rust over arrays: runs everywhere (the compiler may still vectorise it).
    #[default]
    Portable,
    /// 128-bit SSE4.1: four boxes per instruction.
    #[value(name = "sse4.1")]
    Sse41,
    /// 256-bit AVX2: eight boxes per instruction.
    Avx2,
    /// AVX-512 (F + VL) on 128- and 256-bit vectors: mask registers for the lanes hit.
    Avx512,
}

impl SimdLevel {
    pub const ALL: [SimdLevel; 4] = [
        SimdLevel::Portable,
        SimdLevel::Sse41,
        SimdLevel::Avx2,
        SimdLevel::Avx512,
    ];

    pub fn label(self) -> &'static str {
        match self {
            SimdLevel::Portable => "portable",
            SimdLevel::Sse41 => "sse4.1",
            SimdLevel::Avx2 => "avx2",
            SimdLevel::Avx512 => "avx512",
        }
    }

    pub fn from_label(label: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.label() == label)
    }

    /// Whether this machine can run the level's kernels.
    pub fn supported(self) -> bool {
        #[cfg(target_arch = "x86_64")]
        {
            match self {
                SimdLevel::Portable => true,
                SimdLevel::Sse41 => is_x86_feature_detected!("sse4.1"),
                // The walks count and find set bits with single instructions, which every
                // AVX2 CPU has.
                SimdLevel::Avx2 => is_x86_feature_detected!("avx2") && bit_instructions(),
                // The fused slab form needs FMA, which every AVX-512 CPU has.
                SimdLevel::Avx512 => {
                    is_x86_feature_detected!("avx512f")
                        && is_x86_feature_detected!("avx512vl")
                        && is_x86_feature_detected!("fma")
                        && bit_instructions()
                }
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            self == SimdLevel::Portable
        }
    }

    /// The best level this machine supports.
    pub fn detect() -> SimdLevel {
        Self::ALL
            .into_iter()
            .rev()
            .find(|l| l.supported())
            .unwrap_or(SimdLevel::Portable)
    }

    /// The levels this machine supports, the portable one first.
    pub fn available() -> Vec<SimdLevel> {
        Self::ALL.into_iter().filter(|l| l.supported()).collect()
    }
}

/// Whether the CPU counts set bits (`popcnt`) and finds the lowest and highest (`tzcnt`,
/// `lzcnt`) with single instructions: the AVX2 and AVX-512 walks are compiled with them
/// (a packet's active rays are counted at every node).
#[cfg(target_arch = "x86_64")]
fn bit_instructions() -> bool {
    is_x86_feature_detected!("popcnt")
        && is_x86_feature_detected!("bmi1")
        && is_x86_feature_detected!("lzcnt")
}
