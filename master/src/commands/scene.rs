//! `parrt scene`: writes one of the SPD-style generated scenes, or a scene file read with the
//! strict parser, as NFF text or as a POV-Ray scene (to a file or stdout), or lists the
//! generators. Generation lives in the `parrt-scenes` crate and the writers in the library
//! (`parrt_render::nff::to_nff`, `parrt_render::nff::to_pov`); this file only parses arguments, reports errors
//! and writes bytes.

use crate::cli_args::output::{check_distinct, check_file_output};
use crate::cli_args::scene_arg::SceneSpec;
use crate::cli_args::ArgError;
use crate::exit::input_error;
use anyhow::Context;
use clap::{Args, ValueEnum};
use parrt_render::description::SceneDescription;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// What `parrt scene` writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// NFF, one entity per line, SPD's layout.
    Nff,
    /// A POV-Ray 3.7 scene, laid out as Haines' SPD generators write theirs (`-r 4`).
    Pov,
}

/// Arguments of `parrt scene`.
#[derive(Debug, Args)]
#[command(after_help = "\
The format is --format if given, else pov for an output named *.pov, else nff.

Examples: parrt scene mount --factor 6 -o mount-6.nff; parrt scene data/spd/mount-6.nff -o \
mount-6.pov (the POV-Ray version of an NFF file, as bench/peers.sh renders it with POV-Ray).

Exit status: 0 written; 2 bad input (an unknown generator, a malformed or unreadable scene \
file, --factor with a file, --size, the output is the scene file or cannot be written there); 1 any \
other failure (e.g. stdout closed).")]
pub struct SceneArgs {
    /// Generator name (balls, gears, jacks, lattice, mount, rings, shells, sombrero, teapot,
    /// tetra, tree; see --list), or a scene file to read (`*.nff`, parrt's `*.json`, or any
    /// path that exists).
    #[arg(value_name = "NAME|FILE", required_unless_present = "list")]
    pub name: Option<String>,
    /// Size factor, as SPD's `-s N`: how finely the generator subdivides (default: the
    /// generator's SPD default). The same as NAME:N where a scene is named (`render --scene`).
    #[arg(long, short = 's', value_name = "N")]
    pub factor: Option<u32>,
    /// Not a flag of this command: `--size` is an image's size in pixels (WxH) on every
    /// command that takes it; the size factor is --factor. Refused with that said.
    #[arg(long, value_name = "N", hide = true)]
    pub size: Option<String>,
    /// Write the scene to this file instead of stdout.
    #[arg(long, short = 'o', value_name = "FILE")]
    pub output: Option<PathBuf>,
    /// What to write (default: pov for an output named *.pov, else nff).
    #[arg(long, value_enum, value_name = "FORMAT")]
    pub format: Option<Format>,
    /// List the generators with their default sizes and exit.
    #[arg(long, conflicts_with_all = ["factor", "output", "format"])]
    pub list: bool,
}

/// The format to write: the flag, else POV-Ray for an output named `*.pov`, else NFF.
fn format_for(flag: Option<Format>, output: Option<&Path>) -> Format {
    flag.unwrap_or_else(|| {
        let pov = output
            .and_then(|p| p.extension())
            .and_then(|e| e.to_str())
            .is_some_and(|e| e.eq_ignore_ascii_case("pov"));
        if pov {
            Format::Pov
        } else {
            Format::Nff
        }
    })
}

/// The scene `name` names: a generated one, or a file read with the default limits.
fn load(
    name: &str,
    factor: Option<u32>,
    output: Option<&Path>,
) -> anyhow::Result<SceneDescription> {
    let path = PathBuf::from(name);
    let is_file = ["nff", "json"]
        .iter()
        .any(|x| path.extension().is_some_and(|e| e == *x))
        || path.exists();
    if !is_file {
        return parrt_scenes::generate(name, factor).map_err(input_error);
    }
    if factor.is_some() {
        return Err(input_error(anyhow::anyhow!(
            "--factor makes a generated scene; {name} is a file"
        )));
    }
    check_distinct(&[("the scene", Some(path.as_path())), ("-o", output)])?;
    Ok(SceneSpec::file(path).load(&Default::default())?.0)
}

/// The generator table printed by `--list`.
fn listing() -> String {
    let mut out = String::from("generator  default size  description\n");
    for g in parrt_scenes::generators() {
        out.push_str(&format!(
            "{:<10} {:>12}  {}\n",
            g.name, g.default_size, g.about
        ));
    }
    out
}

/// The success line's text: the file, its size and what it holds.
fn summary(path: &Path, scene: &SceneDescription, bytes: usize) -> String {
    let plural = |n: usize, what: &str| format!("{n} {what}{}", if n == 1 { "" } else { "s" });
    format!(
        "{} ({}, {}, {bytes} bytes)",
        path.display(),
        plural(scene.primitives.len(), "primitive"),
        plural(scene.lights.len(), "light")
    )
}

/// Runs `parrt scene`.
pub fn run(args: SceneArgs) -> anyhow::Result<ExitCode> {
    if args.list {
        crate::out!("{}", listing());
        return Ok(ExitCode::SUCCESS);
    }
    let Some(name) = args.name.as_deref() else {
        return Err(input_error(anyhow::anyhow!(
            "give a generator name, or --list to see them"
        )));
    };
    if let Some(size) = &args.size {
        return Err(ArgError::Value(format!(
            "parrt scene takes no --size (an image's size in pixels elsewhere): give the \
             generator's size factor as --factor {size} (or -s {size})"
        ))
        .into());
    }
    if let Some(out) = &args.output {
        check_file_output(out)?;
    }
    let scene = load(name, args.factor, args.output.as_deref())?;
    let text = match format_for(args.format, args.output.as_deref()) {
        Format::Nff => parrt_render::nff::to_nff(&scene),
        Format::Pov => parrt_render::nff::to_pov(&scene),
    };
    match &args.output {
        Some(path) => {
            std::fs::write(path, text.as_bytes())
                .with_context(|| format!("cannot write {}", path.display()))?;
            crate::errln!("parrt: wrote {}", summary(path, &scene, text.len()));
        }
        None => crate::console::write_stdout(text.as_bytes(), "the scene")?,
    }
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn listing_names_every_generator() {
        let l = listing();
        for g in parrt_scenes::generators() {
            assert!(l.contains(g.name));
        }
    }

    #[test]
    fn the_format_comes_from_the_flag_then_the_output_name() {
        let p = |s: &str| PathBuf::from(s);
        assert_eq!(format_for(None, None), Format::Nff);
        assert_eq!(format_for(None, Some(&p("a.POV"))), Format::Pov);
        assert_eq!(format_for(None, Some(&p("a.txt"))), Format::Nff);
        assert_eq!(format_for(Some(Format::Pov), None), Format::Pov);
        assert_eq!(
            format_for(Some(Format::Nff), Some(&p("a.pov"))),
            Format::Nff
        );
    }
}
