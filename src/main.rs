//! The `bvhlab` command line: render, stats and bench over the library.

use anyhow::Result;
use clap::{Parser, Subcommand};

/// `println!` that returns an error instead of panicking when stdout is closed (as in
/// `bvhlab bench | head -1`); `main` treats a broken pipe as a normal end.
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        writeln!(std::io::stdout(), $($arg)*)?
    }};
}

mod cli;

/// The trees' large arrays on huge pages (`bvhlab::huge_pages`).
#[global_allocator]
static ALLOCATOR: bvhlab::huge_pages::HugePages = bvhlab::huge_pages::HugePages;

#[derive(Parser)]
#[command(
    name = "bvhlab",
    version,
    about = "How bounding volume hierarchies make ray–scene queries fast: render, inspect and benchmark.",
    long_about = "How bounding volume hierarchies make ray–scene queries fast: render, inspect and \
                  benchmark.\n\nWithout a command, opens the explorer app.\n\nScenes are built-in names (cornell, teapot-in-stadium, \
                  grass, walls, walls-rotated, same-centroid, same-bbox, soup, sphere, island; most take a \
                  size as NAME:N, e.g. soup:50000 or island:1000) or paths to .obj, .gltf or .glb files."
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    /// The memory the run may plan for: images, ray sets, scenes and structures are sized
    /// before they are made, and one that would not fit is refused at once (default: half
    /// of this machine's memory; e.g. 16G, 512M).
    #[arg(long, global = true, value_parser = bvhlab::budget::parse_size)]
    memory_limit: Option<u64>,
}

// Parsed once per run: the size of its largest variant (bench with its studies) costs nothing.
#[allow(clippy::large_enum_variant)]
#[derive(Subcommand)]
enum Command {
    /// Open the explorer app (the same as no command).
    App(cli::app::AppArgs),
    /// Open the app in a given state, save the window to a PNG, and exit.
    Screenshot(cli::app::ScreenshotArgs),
    /// Render a scene to a PNG through the CPU ray tracer.
    Render(cli::render::RenderArgs),
    /// Build a BVH and print its build report as a table.
    Stats(cli::stats::StatsArgs),
    /// Time builds and the standard primary, diffuse and shadow ray sets.
    Bench(cli::bench::BenchCommand),
    /// Time the explorer's frames (preview and full size) and its drag-to-refit frames.
    Frames(cli::frames::FramesArgs),
    /// Replay one pixel's ray step by step: nodes visited, children tested, pushes, pops and
    /// skips, triangle tests (text or --json).
    Replay(cli::replay::ReplayArgs),
    /// Trace a binary file of rays (closest hit or --any) and write the hits in input order.
    Trace(cli::trace::TraceArgs),
    /// Numerical stress suite: leaks, slab test, degenerate triangles, f64 agreement, shadow
    /// self-hits. Exits non-zero on any failure.
    Stress(cli::stress::StressArgs),
}

/// An error is one line, its causes joined by colons ("cannot load scene 'x': …"), never a
/// "Caused by:" list or a backtrace.
fn main() -> std::process::ExitCode {
    match run() {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn run() -> Result<()> {
    let command = {
        use clap::CommandFactory;
        negative_numbers_are_values(Cli::command())
    };
    let args: Vec<std::ffi::OsString> = std::env::args_os().collect();
    // A global option may stand before and after the command; clap would keep the last.
    let limits = args
        .iter()
        .filter(|a| {
            let a = a.to_string_lossy();
            a == "--memory-limit" || a.starts_with("--memory-limit=")
        })
        .count();
    if limits > 1 {
        command
            .clone()
            .error(
                clap::error::ErrorKind::ArgumentConflict,
                "the argument '--memory-limit <MEMORY_LIMIT>' cannot be used multiple times",
            )
            .exit();
    }
    let matches = command.clone().get_matches_from(study_first(args));
    cli::note_given(&command, &matches);
    let cli = {
        use clap::FromArgMatches;
        Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit())
    };
    // The app's messages do not speak of flags; the other commands say how to go further.
    let in_window = matches!(cli.command, None | Some(Command::App(_)));
    let hint = if in_window {
        ""
    } else {
        "; --memory-limit raises it"
    };
    bvhlab::budget::set_limit(cli.memory_limit, hint);
    let result = match cli.command {
        None => cli::app::run(cli::app::AppArgs::default()),
        Some(Command::App(args)) => cli::app::run(args),
        Some(Command::Screenshot(args)) => cli::app::screenshot(args),
        Some(Command::Render(args)) => cli::render::run(args),
        Some(Command::Stats(args)) => cli::stats::run(args),
        Some(Command::Bench(args)) => cli::bench::run(args),
        Some(Command::Frames(args)) => cli::frames::run(args),
        Some(Command::Trace(args)) => cli::trace::run(args),
        Some(Command::Replay(args)) => cli::replay::run(args),
        Some(Command::Stress(args)) => cli::stress::run(args),
    };
    match result {
        Err(e)
            if e.downcast_ref::<std::io::Error>()
                .is_some_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe) =>
        {
            Ok(())
        }
        other => other,
    }
}

/// `--width -5` reaches the width's own check ("invalid value '-5' for '--width'"), where
/// clap would otherwise call `-5` an unknown flag.
fn negative_numbers_are_values(command: clap::Command) -> clap::Command {
    command
        .allow_negative_numbers(true)
        .mut_subcommands(negative_numbers_are_values)
}

/// `bvhlab bench --scene X builders` means `bvhlab bench builders --scene X`: a study named
/// after `bench`'s options moves to just after `bench`, so the options may come in either
/// order. A token that is an option's value (as in `--csv builders`) stays where it is.
fn study_first(mut args: Vec<std::ffi::OsString>) -> Vec<std::ffi::OsString> {
    use clap::CommandFactory;
    let cli = Cli::command();
    let Some(bench) = cli.find_subcommand("bench") else {
        return args;
    };
    let Some(at) = args.iter().position(|a| a == "bench") else {
        return args;
    };
    let takes_value = |token: &std::ffi::OsStr| {
        let token = token.to_string_lossy();
        let Some(name) = token.strip_prefix("--") else {
            return false;
        };
        let studies = bench.get_subcommands().flat_map(|s| s.get_arguments());
        !name.contains('=')
            && bench
                .get_arguments()
                .chain(studies)
                .any(|a| a.get_long() == Some(name) && a.get_action().takes_values())
    };
    let mut i = at + 1;
    while i < args.len() {
        let is_study = bench
            .get_subcommands()
            .any(|s| args[i].to_str() == Some(s.get_name()));
        if is_study && i > at + 1 && !takes_value(&args[i - 1]) {
            let study = args.remove(i);
            args.insert(at + 1, study);
            break;
        }
        if args[i] == "--" || is_study {
            break;
        }
        i += 1;
    }
    args
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    fn words(line: &str) -> Vec<std::ffi::OsString> {
        line.split(' ').map(Into::into).collect()
    }

    #[test]
    fn a_study_may_follow_benchs_options() {
        assert_eq!(
            study_first(words("bvhlab bench --scene cornell builders --accel bvh8")),
            words("bvhlab bench builders --scene cornell --accel bvh8")
        );
        // Already first, or an option's value: left alone.
        for line in [
            "bvhlab bench builders --scene cornell",
            "bvhlab bench --scene cornell --csv builders",
            "bvhlab render --scene builders",
        ] {
            assert_eq!(study_first(words(line)), words(line));
        }
    }

    #[test]
    fn cli_is_well_formed() {
        Cli::command().debug_assert();
    }
}
