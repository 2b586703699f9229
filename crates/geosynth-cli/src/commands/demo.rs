//! `geosynth demo`: the README's first command.
//!
//! Loads the bundled fixtures (regenerating them in memory when the source tree's
//! `fixtures/` folder is not available), runs every synthesis family the workspace has on
//! them, and writes geometry files, PNG previews, `report.json` and `report.md`.

use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::Args;
use geosynth::core::io::{self, Geometry, WriteOptions};
use geosynth::fixtures::{self, Fixture};
use geosynth::preview::{self, RenderOptions};
use serde::Serialize;

use crate::output::{progress_bar, status};
use crate::{CliResult, Globals, create_dir};

/// Arguments of `geosynth demo`.
#[derive(Debug, Args)]
pub struct DemoArgs {
    /// Output folder (created if missing).
    #[arg(long, default_value = "demo-out")]
    out: PathBuf,
    /// Smaller previews and problem sizes, for a fast smoke run.
    #[arg(long)]
    quick: bool,
    /// Seed of every stochastic stage.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Folder with the fixtures to use (default: the source tree's `fixtures/`).
    #[arg(long)]
    fixtures: Option<PathBuf>,
}

/// The demo's run report.
#[derive(Debug, Serialize)]
struct Report {
    geosynth_version: &'static str,
    seed: u64,
    quick: bool,
    threads: usize,
    fixtures_source: String,
    stages: Vec<StageTiming>,
    fixtures: Vec<FixtureEntry>,
    families: Vec<serde_json::Value>,
}

#[derive(Debug, Serialize)]
struct StageTiming {
    stage: String,
    seconds: f64,
}

#[derive(Debug, Serialize)]
struct FixtureEntry {
    name: String,
    description: String,
    kind: &'static str,
    points: usize,
    faces: usize,
    geometry: String,
    preview: String,
}

/// Loads fixtures from `dir` when every file is there, otherwise generates them.
fn load_fixtures(dir: &Path) -> CliResult<(Vec<Fixture>, String)> {
    let mut generated = fixtures::all()?;
    let all_present = generated.iter().all(|f| dir.join(f.file_name()).is_file());
    if !all_present {
        return Ok((
            generated,
            "generated in memory (fixtures folder not found)".into(),
        ));
    }
    for f in &mut generated {
        f.geometry = io::read_geometry(dir.join(f.file_name()))?.geometry;
    }
    Ok((generated, dir.display().to_string()))
}

fn relative(path: &Path, base: &Path) -> String {
    path.strip_prefix(base)
        .unwrap_or(path)
        .display()
        .to_string()
}

/// Runs `geosynth demo`.
pub fn run(args: &DemoArgs, globals: Globals) -> CliResult {
    let started = Instant::now();
    let mut stages = Vec::new();
    let mut timed = |name: &str, t: Instant| {
        stages.push(StageTiming {
            stage: name.to_string(),
            seconds: t.elapsed().as_secs_f64(),
        });
    };
    let (geometry_dir, preview_dir) = (args.out.join("geometry"), args.out.join("previews"));
    create_dir(&geometry_dir)?;
    create_dir(&preview_dir)?;

    let t = Instant::now();
    let dir = args.fixtures.clone().unwrap_or_else(fixtures::bundled_dir);
    let (fixtures, source) = load_fixtures(&dir)?;
    timed("load fixtures", t);

    let (w, h) = if args.quick { (320, 240) } else { (640, 480) };
    let bar = progress_bar(globals, fixtures.len() as u64, "fixtures");
    let mut entries = Vec::new();
    let t = Instant::now();
    for f in &fixtures {
        let geometry_path = geometry_dir.join(format!("{}.obj", f.name));
        let options = WriteOptions::default().comment(f.description);
        io::write_geometry(&geometry_path, &f.geometry, &options)?;
        let preview_path = preview_dir.join(format!("{}.png", f.name));
        let image = preview::render(&f.geometry, &RenderOptions::default().size(w, h).up(f.up))?;
        preview::save_png(&image, &preview_path)?;
        entries.push(FixtureEntry {
            name: f.name.to_string(),
            description: f.description.to_string(),
            kind: match f.geometry {
                Geometry::Points(_) => "points",
                Geometry::Mesh(_) => "mesh",
            },
            points: f.geometry.points().len(),
            faces: f.geometry.mesh().map_or(0, |m| m.face_count()),
            geometry: relative(&geometry_path, &args.out),
            preview: relative(&preview_path, &args.out),
        });
        bar.inc(1);
    }
    bar.finish_and_clear();
    timed("render fixtures", t);

    let t = Instant::now();
    let panels: Vec<_> = fixtures
        .iter()
        .map(|f| preview::Panel::Geometry(&f.geometry, f.up))
        .collect();
    let overview = preview::render_panels(&panels, &RenderOptions::default().size(w / 2, h / 2))?;
    preview::save_png(&overview, &args.out.join("fixtures.png"))?;
    timed("overview panel", t);
    timed("total", started);

    let report = Report {
        geosynth_version: env!("CARGO_PKG_VERSION"),
        seed: args.seed,
        quick: args.quick,
        threads: rayon::current_num_threads(),
        fixtures_source: source,
        stages,
        fixtures: entries,
        families: Vec::new(),
    };
    write_reports(&report, &args.out)?;
    status(
        globals,
        format!(
            "demo: {} fixtures rendered; results, previews and report in {}",
            report.fixtures.len(),
            args.out.display()
        ),
    );
    Ok(())
}

fn write_reports(report: &Report, out: &Path) -> CliResult {
    let json = serde_json::to_string_pretty(report)?;
    let path = out.join("report.json");
    std::fs::write(&path, json).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    let mut md = String::from("# geosynth demo report\n\n");
    md.push_str(&format!(
        "geosynth {} · seed {} · {} threads · {}\n\nFixtures from: {}\n\n",
        report.geosynth_version,
        report.seed,
        report.threads,
        if report.quick { "quick" } else { "full" },
        report.fixtures_source
    ));
    md.push_str("## Fixtures\n\n| name | kind | points | faces | preview | description |\n|---|---|---:|---:|---|---|\n");
    for f in &report.fixtures {
        md.push_str(&format!(
            "| {} | {} | {} | {} | ![]({}) | {} |\n",
            f.name, f.kind, f.points, f.faces, f.preview, f.description
        ));
    }
    md.push_str("\n## Synthesis families\n\n");
    if report.families.is_empty() {
        md.push_str("No synthesis family is part of this build yet.\n");
    }
    md.push_str("\n## Timings\n\n| stage | seconds |\n|---|---:|\n");
    for s in &report.stages {
        md.push_str(&format!("| {} | {:.3} |\n", s.stage, s.seconds));
    }
    let path = out.join("report.md");
    std::fs::write(&path, md).map_err(|e| format!("cannot write {}: {e}", path.display()).into())
}
