//! Arguments shared by the subcommands, and one file per subcommand.

pub mod app;
pub mod bench;
pub mod compare;
pub mod cracks;
pub mod frames;
pub mod render;
pub mod replay;
pub mod stats;
pub mod stress;
pub mod trace;
pub mod tree;

use anyhow::{Context, Result, bail};
use bvhlab::accel::structure::{self, AccelKind, Built, StructureParams};
use bvhlab::scene::{Camera, Scene};
use clap::{Args, ValueEnum};
use glam::Vec3;

/// The structure and its build parameters, shared by every subcommand that builds one: the
/// library's `StructureParams`, whose fields are the flags.
#[derive(Args, Clone)]
pub struct BuildArgs {
    /// Acceleration structure (`all`: every structure, `bench` only). Default: two-level
    /// for a scene with instances of its own (glTF, island); otherwise, for `render`, `bench`
    /// and `trace`, the fastest layout this machine traces (bvh8 with AVX2 or AVX-512, bvh4
    /// with SSE4.1 only), for the other commands bvh.
    #[arg(long, value_enum)]
    pub accel: Option<AccelArg>,
    #[command(flatten)]
    pub params: StructureParams,
}

/// `--accel`: one structure, or `all` of them (`bench` only).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AccelArg {
    One(AccelKind),
    All,
}

impl ValueEnum for AccelArg {
    fn value_variants<'a>() -> &'a [Self] {
        static VARIANTS: std::sync::OnceLock<Vec<AccelArg>> = std::sync::OnceLock::new();
        VARIANTS.get_or_init(|| {
            let one = AccelKind::value_variants()
                .iter()
                .map(|&k| AccelArg::One(k));
            one.chain([AccelArg::All]).collect()
        })
    }

    fn to_possible_value(&self) -> Option<clap::builder::PossibleValue> {
        match self {
            AccelArg::One(kind) => kind.to_possible_value(),
            AccelArg::All => Some(
                clap::builder::PossibleValue::new("all")
                    .help("Every structure in turn (bench only)"),
            ),
        }
    }
}

impl AccelArg {
    /// The structure this names; `all` is for `bench` only.
    pub fn kind(self) -> Result<AccelKind> {
        match self {
            AccelArg::One(kind) => Ok(kind),
            AccelArg::All => bail!("--accel all is only for `bvhlab bench`; name one structure"),
        }
    }
}

/// The flags given on the command line (their ids, the fields' names), the subcommands'
/// among them: a structure's parameter given for a structure it does nothing for is an
/// error rather than ignored.
static GIVEN: std::sync::OnceLock<Vec<(String, String)>> = std::sync::OnceLock::new();

/// Notes the flags of `matches` and of its subcommands that the command line gave: each
/// one's id and its long name.
pub fn note_given(command: &clap::Command, matches: &clap::ArgMatches) {
    fn collect(c: &clap::Command, m: &clap::ArgMatches, out: &mut Vec<(String, String)>) {
        for id in m.ids() {
            if m.value_source(id.as_str()) == Some(clap::parser::ValueSource::CommandLine) {
                let long = c
                    .get_arguments()
                    .find(|a| a.get_id() == id)
                    .and_then(|a| a.get_long())
                    .unwrap_or(id.as_str());
                out.push((id.to_string(), long.to_string()));
            }
        }
        if let Some((name, sub)) = m.subcommand()
            && let Some(c) = c.find_subcommand(name)
        {
            collect(c, sub, out);
        }
    }
    let mut given = Vec::new();
    collect(command, matches, &mut given);
    let _ = GIVEN.set(given);
}

/// Whether the command line gave the flag `long`.
pub fn was_given(long: &str) -> bool {
    GIVEN
        .get()
        .is_some_and(|g| g.iter().any(|(_, l)| l == long))
}

/// Refuses any flag the command line gave but `used` (long names): the run would ignore
/// it. `why` says what decides instead.
pub fn refuse_unused(used: &[&str], why: &str) -> Result<()> {
    let given = GIVEN.get().map_or(&[][..], |g| g.as_slice());
    match given
        .iter()
        .find(|(_, long)| !used.contains(&long.as_str()) && long != "memory-limit")
    {
        Some((_, long)) => bail!("--{long} does nothing here: {why}"),
        None => Ok(()),
    }
}

/// Refuses a parameter the command line gave that does nothing for `params`' structure.
/// A value out of its range is said first: it is wrong whatever the structure.
pub fn check_given_apply(params: &StructureParams) -> Result<()> {
    params.validate()?;
    let given = GIVEN.get().map_or(&[][..], |g| g.as_slice());
    for n in params.not_applied() {
        if let Some((_, long)) = given.iter().find(|(id, _)| id == n.key) {
            bail!("--{long} {}", n.why);
        }
    }
    Ok(())
}

impl BuildArgs {
    /// The parameters of every structure, for the structure `kind`.
    pub fn structure_params_for(&self, kind: AccelKind) -> StructureParams {
        StructureParams {
            kind,
            ..self.params
        }
    }

    /// The structure `--accel` names, or without it the default for `scene`: the two
    /// levels where the scene has instances of its own (it may be far too large to
    /// flatten), the BVH2 otherwise.
    pub fn accel_for(&self, scene: &Scene) -> AccelArg {
        self.accel
            .unwrap_or(AccelArg::One(if scene.instances.is_empty() {
                AccelKind::Bvh
            } else {
                AccelKind::TwoLevel
            }))
    }

    /// The structure to trace with: the one `--accel` names, or without it the two levels
    /// where the scene has instances of its own, otherwise the fastest layout this machine
    /// traces (`AccelKind::fastest`). `render`, `bench` and `trace` trace with it.
    pub fn accel_to_trace(&self, scene: &Scene) -> AccelArg {
        match self.accel {
            Some(a) => a,
            None if !scene.instances.is_empty() => AccelArg::One(AccelKind::TwoLevel),
            None => AccelArg::One(AccelKind::fastest()),
        }
    }

    /// Whether `accel_to_trace` chose the fastest layout because no `--accel` was given.
    pub fn fastest_by_default(&self, scene: &Scene) -> bool {
        self.accel.is_none() && scene.instances.is_empty()
    }

    /// The parameters of the one structure `--accel` names (or `scene`'s default).
    pub fn structure_params(&self, scene: &Scene) -> Result<StructureParams> {
        Ok(self.structure_params_for(self.accel_for(scene).kind()?))
    }

    /// Builds the structure `--accel` names (or `scene`'s default) over `scene` and says so
    /// on stderr.
    pub fn build(&self, scene: &Scene) -> Result<Built> {
        self.build_kind(scene, self.accel_for(scene), "")
    }

    /// Builds the structure to trace with (`accel_to_trace`) and says so on stderr.
    pub fn build_to_trace(&self, scene: &Scene) -> Result<Built> {
        let note = if self.fastest_by_default(scene) {
            " (the fastest layout on this machine; --accel picks another)"
        } else {
            ""
        };
        self.build_kind(scene, self.accel_to_trace(scene), note)
    }

    fn build_kind(&self, scene: &Scene, accel: AccelArg, note: &str) -> Result<Built> {
        let params = self.structure_params_for(accel.kind()?);
        check_given_apply(&params)?;
        let built = structure::build_scene(scene, &params, &Default::default())
            .with_context(|| format!("cannot build the {}", params.kind.title()))?;
        let simd = built
            .structure
            .simd()
            .map(|l| format!(", {} kernel", l.label()))
            .unwrap_or_default();
        eprintln!(
            "built {} over {} triangles in {:.2} ms{simd}{note}",
            built.report.structure,
            built.report.triangles,
            built.report.build_ms()
        );
        Ok(built)
    }
}

#[derive(Args, Clone)]
pub struct ViewArgs {
    /// Camera position x,y,z (default: the scene's view).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub eye: Option<Vec3>,
    /// Point the camera looks at x,y,z.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub look: Option<Vec3>,
    /// Point light position x,y,z (default: the scene's light).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub light: Option<Vec3>,
}

impl ViewArgs {
    pub fn camera(&self, scene: &Scene) -> Result<Camera> {
        let default = scene.camera();
        let cam = Camera {
            eye: self.eye.unwrap_or(default.eye),
            look_at: self.look.unwrap_or(default.look_at),
            ..default
        };
        if cam.eye == cam.look_at {
            bail!("--eye and --look must be different points");
        }
        Ok(cam)
    }

    pub fn light(&self, scene: &Scene) -> Vec3 {
        self.light.unwrap_or_else(|| scene.light())
    }
}

pub fn parse_vec3(s: &str) -> Result<Vec3, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let [x, y, z] = parts.as_slice() else {
        return Err(format!("expected x,y,z, got '{s}'"));
    };
    let limit = bvhlab::scene::MAX_COORDINATE;
    let f = |v: &str| match v.parse::<f32>() {
        Ok(x) if x.is_finite() && x.abs() <= limit => Ok(x),
        // A number past f32's range reads as infinite: it is beyond the limit too.
        Ok(x) if x.is_finite() || v.trim().parse::<f64>().is_ok_and(f64::is_finite) => Err(
            format!("'{v}' is beyond ±{limit:e}, where ray arithmetic overflows f32"),
        ),
        _ => Err(format!("'{v}' is not a finite number")),
    };
    Ok(Vec3::new(f(x)?, f(y)?, f(z)?))
}

pub fn load_scene(spec: &str) -> Result<Scene> {
    let scene = Scene::load(spec).with_context(|| format!("cannot load scene '{spec}'"))?;
    for warning in &scene.warnings {
        eprintln!("warning: {warning}");
    }
    Ok(scene)
}

/// How many threads `--threads` may ask for, per core: more only adds switching.
const THREADS_PER_CORE: usize = 4;

/// `--threads N`: at least 1 and at most `THREADS_PER_CORE` × this machine's cores, so a
/// typing slip cannot start thousands of threads.
pub fn parse_threads(text: &str) -> Result<usize, String> {
    let n: usize = text
        .parse()
        .map_err(|_| format!("'{text}' is not a thread count"))?;
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let most = THREADS_PER_CORE * cores;
    match n {
        0 => Err("at least 1 thread is needed (leave out --threads for all cores)".into()),
        n if n > most => Err(format!(
            "{n} threads is more than {THREADS_PER_CORE} per core on this machine's {cores} \
             cores (at most {most})"
        )),
        n => Ok(n),
    }
}

/// The most repetitions `--builds` and `--runs` take: more only waits longer for the
/// same best or median.
pub const MAX_REPEATS: u32 = 1000;

/// `--builds N` or `--runs N`: from 1 to `MAX_REPEATS`.
pub fn repeats<T: std::str::FromStr + PartialEq + From<u8> + TryFrom<u32> + PartialOrd>(
    text: &str,
) -> Result<T, String> {
    let n: T = at_least_one(text)?;
    match T::try_from(MAX_REPEATS) {
        Ok(most) if n > most => Err(format!(
            "at most {MAX_REPEATS} repetitions (the best or the median settles long before)"
        )),
        _ => Ok(n),
    }
}

/// A count that must be at least 1 (`--builds`, `--runs`, ray counts): 0 would measure
/// or test nothing and report it as if it had.
pub fn at_least_one<T: std::str::FromStr + PartialEq + From<u8>>(text: &str) -> Result<T, String> {
    match whole_number::<T>(text)? {
        n if n == T::from(0) => Err("must be at least 1".into()),
        n => Ok(n),
    }
}

/// A whole number (`--seed`, `--sizes`), said plainly when it is not one or is too large,
/// rather than as the parser's "invalid digit found in string".
pub fn whole_number<T: std::str::FromStr>(text: &str) -> Result<T, String> {
    match text.parse::<T>() {
        Ok(n) => Ok(n),
        // A whole number too large for the count (u64::MAX and beyond).
        Err(_) if !text.is_empty() && text.bytes().all(|b| b.is_ascii_digit()) => {
            Err(format!("'{text}' is too large"))
        }
        Err(_) => Err(format!("'{text}' is not a whole number")),
    }
}

/// A rayon pool with `threads` workers (default: all cores).
pub fn thread_pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    let mut pool = rayon::ThreadPoolBuilder::new();
    if let Some(n) = threads {
        if n == 0 {
            bail!("--threads must be at least 1");
        }
        pool = pool.num_threads(n);
    }
    pool.build().context("cannot start the worker threads")
}

/// A vertical field of view in degrees, from 1 to 170 (as a preset's camera takes it).
pub fn parse_fov(text: &str) -> Result<f32, String> {
    match text.parse::<f32>() {
        Ok(f) if (1.0..=170.0).contains(&f) => Ok(f),
        _ => Err(format!("'{text}' is not an angle from 1 to 170 degrees")),
    }
}

/// `rays` rays of a study's list (with their hits and the f64 reference's answers), `lists`
/// such lists held at once, within the memory budget.
pub fn rays_within_budget(flag: &str, rays: usize, lists: u64) -> Result<usize> {
    let each = bvhlab::budget::BYTES_PER_RAY * lists;
    bvhlab::budget::check(
        format!("{flag} {rays}"),
        bvhlab::budget::times(rays as u64, each),
    )?;
    Ok(rays)
}

/// `--width` or `--height`: pixels from 1 to `MAX_SIDE`.
pub fn parse_side(text: &str) -> Result<u32, String> {
    match text.parse::<i64>() {
        Ok(n) if (1..=MAX_SIDE as i64).contains(&n) => Ok(n as u32),
        _ => Err(format!(
            "'{text}' is not a size in pixels from 1 to {MAX_SIDE}"
        )),
    }
}

/// The largest image side.
pub const MAX_SIDE: u32 = 16384;

/// An image size within 1..=16384 on each side, whose `frames` frames (two for an A | B
/// comparison) fit the memory budget.
pub fn check_size(width: u32, height: u32, frames: u64) -> Result<()> {
    if !(1..=16384).contains(&width) || !(1..=16384).contains(&height) {
        bail!("image size {width}×{height} must be within 1..=16384 on each side");
    }
    let pixels = width as u64 * height as u64;
    let what = match frames {
        1 => format!("an image of {width}×{height} pixels"),
        n => format!("{n} images of {width}×{height} pixels"),
    };
    let each = bvhlab::budget::FRAME_BYTES_PER_PIXEL * frames;
    bvhlab::budget::check(what, bvhlab::budget::times(pixels, each))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thread_counts_are_bounded() {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        assert_eq!(parse_threads("1"), Ok(1));
        assert_eq!(parse_threads(&(4 * cores).to_string()), Ok(4 * cores));
        assert!(parse_threads("0").unwrap_err().contains("at least 1"));
        let many = parse_threads(&(4 * cores + 1).to_string()).unwrap_err();
        assert!(many.contains("at most"), "{many}");
        assert!(parse_threads("x").is_err());
    }

    #[test]
    fn vec3_parsing() {
        assert_eq!(parse_vec3("1,-2, 3.5"), Ok(Vec3::new(1.0, -2.0, 3.5)));
        assert!(parse_vec3("1,2").is_err());
        assert!(parse_vec3("1,2,nan").is_err());
        assert!(parse_vec3("a,b,c").is_err());
        assert!(parse_vec3("0,1e20,0").unwrap_err().contains("beyond"));
    }
}

/// How a command finds the tree's EPO (`stats`, and the SAH check of `bench`).
#[derive(Args, Clone, Copy)]
pub struct EpoArgs {
    /// How the EPO is found: `exact` clips every triangle into every box it crosses (the
    /// two levels past 2^21 placed triangles estimate instead); `estimate` averages
    /// `--end-points` end points drawn uniformly by area, with a standard error, in a
    /// fraction of the time.
    #[arg(long, value_enum, default_value = "exact")]
    pub epo: EpoMethod,
    /// End points `--epo estimate` averages (2 to 2^30).
    #[arg(long, default_value_t = bvhlab::accel::epo::end_points::DEFAULT_END_POINTS,
          value_parser = clap::value_parser!(u64).range(2..=1 << 30))]
    pub end_points: u64,
}

/// `--epo`'s values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum EpoMethod {
    Exact,
    Estimate,
}

impl EpoArgs {
    pub fn way(&self) -> bvhlab::accel::epo::EpoWay {
        match self.epo {
            EpoMethod::Exact => bvhlab::accel::epo::EpoWay::Exact,
            EpoMethod::Estimate => bvhlab::accel::epo::EpoWay::Estimate {
                end_points: self.end_points,
            },
        }
    }
}
