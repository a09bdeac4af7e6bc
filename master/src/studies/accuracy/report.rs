//! The study's tables (Markdown and CSV, the latter with the `csv` crate) and its
//! recommendation. Pure text: the caller writes the files.

use super::configs::{REF_DEPTH, REF_SPP};
use super::metrics::ONE_STEP;
use super::pareto::front;
use super::study::{Row, SceneStudy};
use parrt_render::settings::Precision;
use std::fmt::Write;

/// A configuration is "good enough" when the RMSE of its truncation error (against the f64,
/// depth-16, no-cut-off render with the same samples) is at most half an 8-bit step: what the
/// cut-off, depth limit and precision lose is then below what the output can show on average.
/// (A share-of-pixels criterion is reported too, but mirror pairs such as mount's spheres keep
/// a few percent of pixels changing up to depth 16, so it cannot pick a depth ≤ 8.)
pub const GOOD_ENOUGH_RMSE: f64 = 0.5 / 255.0;

/// Indices of a study's rows on the time–RMSE Pareto front.
pub fn front_of(study: &SceneStudy) -> Vec<usize> {
    let pts: Vec<(f64, f64)> = study.rows.iter().map(|r| (r.time, r.error.rmse)).collect();
    front(&pts)
}

fn db(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.1}")
    } else {
        "inf".to_string()
    }
}

/// The columns of `accuracy.csv`, which `parrt bench accuracy --replot` reads back.
pub const CSV_HEADER: [&str; 16] = [
    "scene",
    "cutoff",
    "depth",
    "precision",
    "spp",
    "trace_s",
    "rays",
    "rmse",
    "psnr_db",
    "max_err",
    "off_share",
    "trunc_rmse",
    "trunc_psnr_db",
    "trunc_max_err",
    "trunc_off_share",
    "pareto",
];

/// The CSV of every study (header included).
pub fn csv(studies: &[SceneStudy]) -> anyhow::Result<String> {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record(CSV_HEADER)?;
    for st in studies {
        let f = front_of(st);
        for (i, r) in st.rows.iter().enumerate() {
            let c = &r.config;
            w.write_record([
                st.scene.clone(),
                c.cutoff.to_string(),
                c.depth.to_string(),
                c.precision_name().to_string(),
                c.spp.to_string(),
                format!("{:.6}", r.time),
                r.rays.to_string(),
                format!("{:.7}", r.error.rmse),
                format!("{:.3}", r.error.psnr),
                format!("{:.6}", r.error.max),
                format!("{:.6}", r.error.off),
                format!("{:.7}", r.truncation.rmse),
                format!("{:.3}", r.truncation.psnr),
                format!("{:.6}", r.truncation.max),
                format!("{:.6}", r.truncation.off),
                f.contains(&i).to_string(),
            ])?;
        }
    }
    Ok(String::from_utf8(w.into_inner()?)?)
}

fn is_plain(r: &Row) -> bool {
    r.config.precision == Precision::F32 && r.config.spp == 1
}

/// The cheapest f32 one-sample row of a study that is good enough, if any.
pub fn cheapest_good(st: &SceneStudy) -> Option<&Row> {
    st.rows
        .iter()
        .filter(|r| is_plain(r) && r.truncation.rmse <= GOOD_ENOUGH_RMSE)
        .min_by(|a, b| a.time.total_cmp(&b.time))
}

/// The (cut-off, depth) good enough on every scene with the smallest sum over scenes of its time
/// relative to that scene's default configuration.
pub fn recommend(studies: &[SceneStudy]) -> Option<(f64, u32, f64)> {
    let first = studies.first()?;
    let mut best: Option<(f64, u32, f64)> = None;
    for cand in first.rows.iter().filter(|r| is_plain(r)) {
        let (c, d) = (cand.config.cutoff, cand.config.depth);
        let mut total = 0.0;
        let mut ok = true;
        for st in studies {
            let row = st
                .rows
                .iter()
                .find(|r| is_plain(r) && r.config.cutoff == c && r.config.depth == d);
            let default = st.rows.iter().find(|r| r.config.is_default());
            match (row, default) {
                (Some(r), Some(def)) if r.truncation.rmse <= GOOD_ENOUGH_RMSE => {
                    total += r.time / def.time.max(1e-9);
                }
                _ => ok = false,
            }
        }
        let n = studies.len() as f64;
        if ok && best.is_none_or(|b| total / n < b.2) {
            best = Some((c, d, total / n));
        }
    }
    best
}

/// The name of a scene's page beside `accuracy.md`: `accuracy-<scene>.md`.
pub fn page_name(st: &SceneStudy) -> String {
    format!("accuracy-{}.md", st.scene)
}

/// The study's front page, `accuracy.md`: the method, one line per scene (its reference and
/// its cheapest good configuration, linking to the scene's page), the recommendation and what
/// the plots show. Each scene's full table is on its own page ([`scene_page`]), so no page
/// grows with the number of scenes times the grid.
pub fn markdown(studies: &[SceneStudy], width: u32, height: u32, threads: usize) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# Speed against error\n\n{width}×{height} pixels, {threads} render threads, trace time \
         only. Reference: f64, no cut-off, depth {REF_DEPTH}, {REF_SPP} stratified samples per \
         pixel. Errors on the linear float film clamped to [0, 1]: RMSE over all pixels and \
         channels, PSNR = 20·log10(1/RMSE), max = largest channel difference, off = share of \
         pixels with a channel off by more than 1/255. `trunc` columns compare with the f64, \
         depth-{REF_DEPTH}, no-cut-off render with the *same* samples, isolating what cut-off, \
         depth and precision cost from sampling error. `front` marks the time–RMSE Pareto front; \
         **bold** is the default configuration.\n\n## Scenes\n"
    );
    for st in studies {
        let good = match cheapest_good(st) {
            Some(r) => format!(
                "cheapest good f32/1-sample configuration: cut-off {}, depth {} ({:.3} s)",
                r.config.cutoff, r.config.depth, r.time
            ),
            None => "no f32/1-sample configuration good enough".to_string(),
        };
        let _ = writeln!(
            s,
            "- [{}]({}): reference {:.3} s, {} rays; {good}.",
            st.scene,
            page_name(st),
            st.reference_time,
            st.reference_rays
        );
    }
    let _ = writeln!(s);
    match recommend(studies) {
        Some((c, d, rel)) => {
            let _ = writeln!(
                s,
                "## Recommendation\n\nCut-off {c}, depth {d}: truncation RMSE ≤ {:.5} (half of \
                 {:.5}) on every scene, at {:.2}× the default's trace time on average.",
                GOOD_ENOUGH_RMSE, ONE_STEP, rel
            );
        }
        None => {
            let _ = writeln!(
                s,
                "## Recommendation\n\nNo single f32/1-sample configuration was good enough on \
                 every scene."
            );
        }
    }
    let _ = writeln!(
        s,
        "\nPlots: `pareto-<scene>.svg` and `.png`: x = trace seconds, y = RMSE against the \
         reference, both log scale; grey f32/1 sample, green f64/1 sample, orange \
         4 samples, red line the Pareto front, blue ring the default."
    );
    s
}

/// One scene's page: every configuration of the grid with its time, rays and errors, and the
/// cheapest f32/1-sample configuration whose truncation error is at most half a step of 8 bits.
pub fn scene_page(st: &SceneStudy, width: u32, height: u32) -> String {
    let mut s = String::new();
    let f = front_of(st);
    let _ = writeln!(
        s,
        "# Speed against error: {}\n\n{width}×{height} pixels; the method and the columns are \
         described in [accuracy.md](accuracy.md).\n\nReference: {:.3} s, {} rays.\n\n\
         | cut-off | depth | prec | spp | time s | rays | RMSE | PSNR dB | max | off | trunc RMSE | trunc off | front |\n\
         |---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|:-:|",
        st.scene, st.reference_time, st.reference_rays
    );
    for (i, r) in st.rows.iter().enumerate() {
        let c = &r.config;
        let b = if c.is_default() { "**" } else { "" };
        let _ = writeln!(
            s,
            "| {b}{}{b} | {b}{}{b} | {} | {} | {:.3} | {} | {:.5} | {} | {:.3} | {:.4} | {:.5} | {:.4} | {} |",
            c.cutoff,
            c.depth,
            c.precision_name(),
            c.spp,
            r.time,
            r.rays,
            r.error.rmse,
            db(r.error.psnr),
            r.error.max,
            r.error.off,
            r.truncation.rmse,
            r.truncation.off,
            if f.contains(&i) { "●" } else { "" }
        );
    }
    if let Some(r) = cheapest_good(st) {
        let _ = writeln!(
            s,
            "\nCheapest f32/1-sample configuration whose truncation RMSE is at most {:.5} \
             (half of 1/255): cut-off {}, depth {} ({:.3} s).",
            GOOD_ENOUGH_RMSE, r.config.cutoff, r.config.depth, r.time
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::super::configs::Config;
    use super::super::metrics::ImageError;
    use super::*;

    fn err(rmse: f64, off: f64) -> ImageError {
        ImageError {
            rmse,
            psnr: 20.0 * (1.0 / rmse).log10(),
            max: rmse * 3.0,
            off,
        }
    }

    fn row(cutoff: f64, depth: u32, time: f64, off: f64) -> Row {
        Row {
            config: Config {
                cutoff,
                depth,
                precision: Precision::F32,
                spp: 1,
            },
            time,
            rays: 100,
            error: err(0.01 + off, off),
            truncation: err(off + 1e-4, off),
        }
    }

    fn study(rows: Vec<Row>) -> SceneStudy {
        SceneStudy {
            scene: "s".into(),
            reference_time: 1.0,
            reference_rays: 1000,
            rows,
        }
    }

    #[test]
    fn recommends_the_cheapest_configuration_good_on_every_scene() {
        let a = study(vec![
            row(0.001, 5, 1.0, 0.0),
            row(0.1, 2, 0.5, 0.0),
            row(0.1, 1, 0.3, 0.2),
        ]);
        let b = study(vec![
            row(0.001, 5, 2.0, 0.0),
            row(0.1, 2, 1.5, 0.0),
            row(0.1, 1, 1.0, 0.0),
        ]);
        let (c, d, rel) = recommend(&[a.clone(), b]).expect("one fits");
        assert_eq!((c, d), (0.1, 2));
        assert!((rel - (0.5 + 0.75) / 2.0).abs() < 1e-12);
        assert_eq!(cheapest_good(&a).map(|r| r.config.depth), Some(2));
        let text = scene_page(&a, 8, 8);
        assert!(text.contains("| **0.001** | **5** |"), "{text}");
        let index = markdown(std::slice::from_ref(&a), 8, 8, 1);
        assert!(
            index.contains(&format!(
                "- [{}](accuracy-{}.md): reference ",
                a.scene, a.scene
            )),
            "{index}"
        );
        let csv = csv(&[a]).expect("writes");
        assert_eq!(csv.lines().count(), 4);
        assert!(csv.starts_with(
            "scene,cutoff,depth,precision,spp,trace_s,rays,rmse,psnr_db,max_err,off_share,\
             trunc_rmse,trunc_psnr_db,trunc_max_err,trunc_off_share,pareto\n"
        ));
        assert!(csv
            .lines()
            .nth(1)
            .is_some_and(|l| l.starts_with("s,0.001,5,f32,1,")));
    }
}
