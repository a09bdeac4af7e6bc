//! Development and timing tool: `gen NAME [SIZE]` prints the scene as NFF on stdout;
//! `gen --time [REPEATS]` times the generation of every default-size scene (and the two teapot
//! sizes and mount 10) and prints a table. Run it with `cargo run --release --example gen`.

use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        Some("--time") => {
            let repeats: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(5);
            let mut cases: Vec<(&str, u32)> = parrt_scenes::generators()
                .iter()
                .map(|g| (g.name, g.default_size))
                .collect();
            cases.push(("teapot", 12));
            cases.push(("mount", 8));
            cases.push(("mount", 10));
            println!("| scene | size | primitives | median ms | min ms |");
            println!("|---|---:|---:|---:|---:|");
            for (name, size) in cases {
                let mut times = Vec::new();
                let mut count = 0;
                let reps = if size >= 10 { 3 } else { repeats };
                for _ in 0..reps {
                    let t0 = Instant::now();
                    let scene = match parrt_scenes::generate(name, Some(size)) {
                        Ok(s) => s,
                        Err(e) => {
                            eprintln!("{e}");
                            std::process::exit(1);
                        }
                    };
                    times.push(t0.elapsed().as_secs_f64() * 1e3);
                    count = scene.primitives.len();
                    drop(scene);
                }
                times.sort_by(f64::total_cmp);
                println!(
                    "| {name} | {size} | {count} | {:.2} | {:.2} |",
                    times[times.len() / 2],
                    times[0]
                );
            }
        }
        Some(name) => {
            let size = args.get(1).and_then(|s| s.parse().ok());
            match parrt_scenes::generate(name, size) {
                Ok(scene) => print!("{}", parrt_render::nff::to_nff(&scene)),
                Err(e) => {
                    eprintln!("{e}");
                    std::process::exit(2);
                }
            }
        }
        None => {
            eprintln!("usage: gen NAME [SIZE] | gen --time [REPEATS]");
            std::process::exit(2);
        }
    }
}
