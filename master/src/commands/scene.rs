//! `parrt scene`: writes one of the SPD-style generated scenes as NFF text (to a file or stdout),
//! or lists the generators. Generation itself lives in the `parrt-scenes` crate; this file only
//! parses arguments, reports errors and writes bytes.

use crate::cli_args::ArgError;
use crate::exit::input_error;
use anyhow::Context;
use clap::Args;
use std::path::PathBuf;
use std::process::ExitCode;

/// Arguments of `parrt scene`.
#[derive(Debug, Args)]
pub struct SceneArgs {
    /// Generator name (balls, gears, jacks, lattice, mount, rings, shells, sombrero, teapot,
    /// tetra, tree); see --list.
    #[arg(value_name = "NAME", required_unless_present = "list")]
    pub name: Option<String>,
    /// Size factor, as SPD's `-s N`: how finely the generator subdivides (default: the
    /// generator's SPD default). The same as NAME:N where a scene is named (`render --scene`).
    #[arg(long, short = 's', value_name = "N")]
    pub factor: Option<u32>,
    /// Not a flag of this command: `--size` is an image's size in pixels (WxH) on every
    /// command that takes it; the size factor is --factor. Refused with that said.
    #[arg(long, value_name = "N", hide = true)]
    pub size: Option<String>,
    /// Write the NFF to this file instead of stdout.
    #[arg(long, short = 'o', value_name = "FILE")]
    pub output: Option<PathBuf>,
    /// List the generators with their default sizes and exit.
    #[arg(long, conflicts_with_all = ["factor", "output"])]
    pub list: bool,
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
fn summary(
    path: &std::path::Path,
    scene: &parrt::description::SceneDescription,
    bytes: usize,
) -> String {
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
    if let Some(size) = &args.size {
        return Err(ArgError::Value(format!(
            "parrt scene takes no --size (an image's size in pixels elsewhere): give the \
             generator's size factor as --factor {size} (or -s {size})"
        ))
        .into());
    }
    let Some(name) = args.name.as_deref() else {
        return Err(input_error(anyhow::anyhow!(
            "give a generator name, or --list to see them"
        )));
    };
    let scene = parrt_scenes::generate(name, args.factor).map_err(input_error)?;
    let text = parrt::nff::to_nff(&scene);
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
}
