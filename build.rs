//! Compiles the tinybvh peer's C interface (peers/tinybvh) with the `tinybvh` feature;
//! nothing otherwise.

fn main() {
    #[cfg(feature = "tinybvh")]
    {
        println!("cargo:rerun-if-changed=peers/tinybvh/shim.cpp");
        println!("cargo:rerun-if-changed=peers/tinybvh/tiny_bvh.h");
        // AVX2 and FMA: tinybvh's BVH8_CPU needs them (its header leaves it out without).
        cc::Build::new()
            .cpp(true)
            .file("peers/tinybvh/shim.cpp")
            .flag("-std=c++17")
            .flag("-mavx2")
            .flag("-mfma")
            .opt_level(3)
            .warnings(false)
            .compile("bvhlab_tinybvh");
    }
}
