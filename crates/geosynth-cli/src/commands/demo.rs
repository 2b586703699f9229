//! `geosynth demo`: the README's first command.
//!
//! Loads the bundled fixtures (regenerating them in memory when the source tree's
//! `fixtures/` folder is not available), runs every synthesis family the workspace has on
//! them, and writes geometry files, PNG previews, `report.json` and `report.md`. With the
//! shared data it also reconstructs real scans and quilts a real terrain into a height map
//! ([`super::demo_terrain`]).

use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::Args;
use geosynth::core::io::{self, Geometry, WriteOptions, write_whole};
use geosynth::core::simplify::SimplifyParams;
use geosynth::fixtures::{self, Fixture};
use geosynth::preview::{self, RenderOptions};
use geosynth::quilt::{Method, OutputSize, QualityReport, QuiltParams};
use geosynth::reconstruct::{FieldParams, Reconstruct};
use geosynth::sdf::PointSign;
use geosynth::simplify::Simplify;
use geosynth::tps::{PairingParams, Table1Preset};
use geosynth::{RunContext, Stage};
use serde::Serialize;

use crate::commands::demo_terrain::{TERRAIN, TerrainEntry, quilt_terrain};
use crate::commands::quilt::{measure_for, measured_run, run_json, texture_preview};
use crate::json_report::write_json_report;
use crate::memory::peak_resident_bytes;
use crate::output::{progress_bar, status, write_geometry_file};
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
    /// Folder with the shared real-world data (default: `$GEOSYNTH_DATA`, else
    /// `../shared/data` beside the source tree); parts that need it are skipped without it.
    #[arg(long)]
    data: Option<PathBuf>,
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
    reconstructions: Vec<ReconstructionEntry>,
    quilts: Vec<QuiltEntry>,
    terrain: Vec<TerrainEntry>,
    volumes: Vec<VolumeEntry>,
    skipped: Vec<String>,
}

/// One solid synthesized by distance-field block matching and by random blocks.
#[derive(Debug, Serialize)]
struct VolumeEntry {
    exemplar: String,
    exemplar_geometry: String,
    geometry: String,
    isosurface: String,
    preview: String,
    run: serde_json::Value,
    beats_baseline: bool,
}

/// One exemplar quilted by the paper's method, the two baselines and the same-layout control.
#[derive(Debug, Serialize)]
struct QuiltEntry {
    exemplar: String,
    input_points: usize,
    scale: f32,
    geometry: String,
    preview: String,
    /// The full run's parameters (the baselines change only the method or the layout).
    params: QuiltParams,
    full: serde_json::Value,
    search_only: serde_json::Value,
    random_placement: serde_json::Value,
    /// The full run's patches pasted without warp or blend (the control for steps 4–5).
    same_layout_pasted: serde_json::Value,
    full_beats_baselines: bool,
}

/// A point set to reconstruct, and how its field is signed.
struct ReconstructionJob {
    name: String,
    input: PathBuf,
    sign: PointSign,
}

/// One point set turned into a mesh.
#[derive(Debug, Serialize)]
struct ReconstructionEntry {
    name: String,
    input: String,
    input_points: usize,
    /// `--sign`: `local` (the MLS surface's own) or `winding` (the points' winding number).
    sign: &'static str,
    resolution: usize,
    vertices: usize,
    faces: usize,
    closed_manifold: bool,
    components: usize,
    euler_characteristic: i64,
    seconds_distance_field: f64,
    seconds_isosurface: f64,
    geometry: String,
    /// The reconstruction simplified to a tenth of its faces (`geosynth simplify`).
    simplified: SimplifiedEntry,
    preview: String,
}

/// A reconstruction simplified by edge collapse: its counts, topology and file.
#[derive(Debug, Serialize)]
struct SimplifiedEntry {
    faces: usize,
    closed_manifold: bool,
    euler_characteristic: i64,
    max_collapse_error: f64,
    seconds: f64,
    geometry: String,
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

pub(super) fn relative(path: &Path, base: &Path) -> String {
    path.strip_prefix(base)
        .unwrap_or(path)
        .display()
        .to_string()
}

/// Runs `geosynth demo`.
pub fn run(args: &DemoArgs, globals: Globals) -> CliResult {
    if let Some(data) = &args.data
        && !data.is_dir()
    {
        return Err(format!(
            "--data {}: not a folder (give the shared data folder, the one holding \
             pointsets/ and heightfields/)",
            data.display()
        )
        .into());
    }
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
        write_geometry_file(&geometry_path, &f.geometry, &options, globals)?;
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

    let t = Instant::now();
    let data_dir = args
        .data
        .clone()
        .or_else(|| std::env::var_os("GEOSYNTH_DATA").map(PathBuf::from))
        .unwrap_or_else(|| {
            fixtures::bundled_dir()
                .join("..")
                .join("..")
                .join("shared")
                .join("data")
        });
    let mut skipped = Vec::new();
    let job = |name: &str, input: PathBuf, sign| ReconstructionJob {
        name: name.into(),
        input,
        sign,
    };
    let mut jobs = vec![job(
        "torus_points",
        dir.join("torus_points.ply"),
        PointSign::Implicit,
    )];
    let bunny = data_dir.join("pointsets").join("bunny16k_normals.ply");
    if bunny.is_file() {
        jobs.push(job("bunny16k", bunny, PointSign::Implicit));
    } else {
        skipped.push(format!(
            "bunny reconstruction: {} not found (set GEOSYNTH_DATA or --data)",
            bunny.display()
        ));
    }
    // The chameleon's thin tongue, toes and tail and its stray normals break the MLS
    // surface's own sign apart; its winding number keeps the animal whole. Both shown.
    let chameleon = data_dir.join("pointsets").join("chameleon4k_normals.ply");
    if chameleon.is_file() {
        jobs.push(job("chameleon", chameleon.clone(), PointSign::Implicit));
        jobs.push(job(
            "chameleon_winding",
            chameleon,
            PointSign::WindingNumber,
        ));
    } else {
        skipped.push(format!(
            "chameleon reconstructions: {} not found (set GEOSYNTH_DATA or --data)",
            chameleon.display()
        ));
    }
    let resolution = if args.quick { 48 } else { 96 };
    let mut reconstructions = Vec::new();
    let bar = progress_bar(globals, jobs.len() as u64, "reconstruct");
    for job in &jobs {
        let points = match io::read_geometry(&job.input) {
            Ok(l) => l.geometry.points().clone(),
            // The torus comes from the fixtures, which may be in memory only.
            Err(_) => fixtures
                .iter()
                .find(|f| f.name == job.name)
                .map(|f| f.geometry.points().clone())
                .ok_or("missing input")?,
        };
        reconstructions.push(reconstruct_one(
            job,
            points,
            resolution,
            (w, h),
            &args.out,
            globals,
        )?);
        bar.inc(1);
    }
    bar.finish_and_clear();
    timed("reconstructions", t);

    let t = Instant::now();
    let quilts = quilt_textures(&dir, args, globals)?;
    timed("quilts", t);
    let t = Instant::now();
    let terrain_path = data_dir.join(TERRAIN);
    let mut terrain = Vec::new();
    if terrain_path.is_file() {
        terrain.push(quilt_terrain(
            &terrain_path,
            &args.out,
            args.quick,
            args.seed,
            globals,
        )?);
    } else {
        skipped.push(format!(
            "terrain height map: {} not found (set GEOSYNTH_DATA or --data)",
            terrain_path.display()
        ));
    }
    timed("terrain", t);
    let t = Instant::now();
    let volumes = synthesize_volumes(args, globals)?;
    timed("voxel synthesis", t);
    timed("total", started);

    let report = Report {
        geosynth_version: env!("CARGO_PKG_VERSION"),
        seed: args.seed,
        quick: args.quick,
        threads: rayon::current_num_threads(),
        fixtures_source: source,
        stages,
        fixtures: entries,
        reconstructions,
        quilts,
        terrain,
        volumes,
        skipped,
    };
    write_reports(&report, &args.out)?;
    for part in &report.skipped {
        status(globals, format!("skipped: {part}"));
    }
    status(
        globals,
        format!(
            "demo: {} rendered, {}, {}, {}, {} synthesized; results, previews and report in {}",
            counted(report.fixtures.len(), "fixture"),
            counted(report.reconstructions.len(), "reconstruction"),
            counted(report.quilts.len(), "quilt"),
            counted(report.terrain.len(), "height map"),
            counted(report.volumes.len(), "solid"),
            args.out.display()
        ),
    );
    Ok(())
}

/// `count` and `noun`, in the plural unless one.
fn counted(count: usize, noun: &str) -> String {
    if count == 1 {
        format!("1 {noun}")
    } else {
        format!("{count} {noun}s")
    }
}

fn write_reports(report: &Report, out: &Path) -> CliResult {
    write_json_report(&out.join("report.json"), "demo", report)?;
    let mut md = String::from("# geosynth demo report\n\n");
    let peak = match peak_resident_bytes() {
        Some(bytes) => format!("{:.0} MiB", bytes as f64 / f64::from(1 << 20)),
        None => "not known on this platform".to_string(),
    };
    md.push_str(&format!(
        "geosynth {} · seed {} · {} threads · {} · peak memory {peak}\n\nFixtures from: {}\n\n",
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
    md.push_str("\n## Reconstructions (MLS surface → distance field → iso-surface)\n\n");
    md.push_str("| input | points | sign | grid | vertices | faces | closed manifold | components | χ | field s | iso s | simplified faces (closed, χ) | simplify s | preview |\n|---|---:|---|---:|---:|---:|---|---:|---:|---:|---:|---|---:|---|\n");
    for r in &report.reconstructions {
        md.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.2} | {:.2} | {} ({}, {}) | {:.2} | ![]({}) |\n",
            r.name,
            r.input_points,
            r.sign,
            r.resolution,
            r.vertices,
            r.faces,
            r.closed_manifold,
            r.components,
            r.euler_characteristic,
            r.seconds_distance_field,
            r.seconds_isosurface,
            r.simplified.faces,
            r.simplified.closed_manifold,
            r.simplified.euler_characteristic,
            r.simplified.seconds,
            r.preview
        ));
    }
    md.push_str("\n## Patch quilting (paper 000)\n\nErrors are normalized nearest-exemplar-window errors of the signed distance, the nearest window searched at continuous offsets (0 = like some part of the exemplar, 1 = as different as two unrelated parts); continued = share of seams where the two patches are neighbours in the exemplar too (one intact region copied across the seam); LED = largest empty disc (output / exemplar). Each exemplar uses the pairing weights of its Table 1 row. \"full's layout, pasted\" pastes the full run's patches without warp or blend: the difference to \"full\" is what steps 4–5 (warp, blend) did. These are one seed: the layout alone moves a fixture's errors from seed to seed, often by more than the methods differ, so compare methods on the means over 16 seeds in docs/patch-quilt-studies.md (`cargo run --release --example quilt_study`).\n\n");
    md.push_str("| exemplar | method | seconds | patches | mean Ψ | mean pairs | points | neighbourhood | seam | interior | seam / interior | verbatim | continued | LED |\n|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|\n");
    for q in &report.quilts {
        for (name, run) in [
            ("full", &q.full),
            ("search only", &q.search_only),
            ("random placement", &q.random_placement),
            ("full's layout, pasted", &q.same_layout_pasted),
        ] {
            let f = |k: &str| run["quality"][k].as_f64().unwrap_or(f64::NAN);
            md.push_str(&format!(
                "| {} | {} | {:.2} | {} | {:.1} | {:.1} | {} | {:.3} | {:.3} | {:.3} | {:.2} | {:.2} | {:.2} | {:.3} / {:.3} |\n",
                q.exemplar, name, run["seconds"].as_f64().unwrap_or(0.0), run["patches"], run["mean_candidates"].as_f64().unwrap_or(0.0),
                run["mean_pairs"].as_f64().unwrap_or(0.0), run["output_points"], f("neighbourhood_error"), f("seam_error"),
                f("interior_error"), f("seam_concentration"), f("verbatim_fraction"), f("continued_seams"), f("largest_empty_disc"), f("exemplar_largest_empty_disc")
            ));
        }
    }
    for q in &report.quilts {
        md.push_str(&format!("\n![{}]({}) ", q.exemplar, q.preview));
    }
    if !report.terrain.is_empty() {
        md.push_str("\n\n### A height field in, a height map out\n\nA real terrain quilted from its height field and written back as a 16-bit height map on its own sample spacing (`geosynth quilt --heightfield IMG --heightfield-out MAP.png`); the preview draws input | output at one height scale. Filled = samples over holes in the quilted points, filled from the heights around them.\n\n| exemplar | scale | map | samples | filled | quilt s | map s | preview |\n|---|---:|---|---|---:|---:|---:|---|\n");
        for t in &report.terrain {
            md.push_str(&format!(
                "| {} | {} | {} | {} × {} | {} | {:.2} | {:.2} | ![]({}) |\n",
                t.exemplar,
                t.scale,
                t.height_map,
                t.width,
                t.height,
                t.filled,
                t.seconds_quilt,
                t.seconds_heights,
                t.preview
            ));
        }
    }
    md.push_str("\n## Distance-field synthesis (paper 001)\n\nNeighbourhood and seam errors are normalized by the source's own window / sample variation (0 = like the source); DF = share of samples whose gradient has unit length (source in brackets); verbatim = neighbouring blocks copied together.\n\n");
    md.push_str("| exemplar | method | seconds | neighbourhood | seam | DF | verbatim | copied triangles | open edges before → after weld |\n|---|---|---:|---:|---:|---:|---:|---:|---|\n");
    for v in &report.volumes {
        let r = &v.run;
        let c = &r["copied"];
        let mesh = format!(
            "{} | {} → {}",
            c["triangles"], c["boundary_edges_before"], c["boundary_edges_after"]
        );
        let seconds = format!("{:.1}", r["seconds"].as_f64().unwrap_or(0.0));
        for (name, q, seconds, mesh) in [
            ("search", &r["quality"], seconds, mesh),
            (
                "random blocks",
                &r["random_baseline"],
                "–".to_string(),
                "– | –".to_string(),
            ),
        ] {
            let f = |k: &str| q[k].as_f64().unwrap_or(f64::NAN);
            md.push_str(&format!(
                "| {} | {} | {} | {:.3} | {:.3} | {:.2} ({:.2}) | {:.2} | {} |\n",
                v.exemplar,
                name,
                seconds,
                f("neighbourhood_error"),
                f("seam_error"),
                f("distance_field_fraction"),
                f("source_distance_field_fraction"),
                f("verbatim_fraction"),
                mesh
            ));
        }
    }
    for v in &report.volumes {
        md.push_str(&format!("\n![{}]({}) ", v.exemplar, v.preview));
    }
    md.push('\n');
    for s in &report.skipped {
        md.push_str(&format!("\nSkipped: {s}\n"));
    }
    md.push_str("\n## Timings\n\n| stage | seconds |\n|---|---:|\n");
    for s in &report.stages {
        md.push_str(&format!("| {} | {:.3} |\n", s.stage, s.seconds));
    }
    let path = out.join("report.md");
    write_whole(&path, md).map_err(|e| format!("cannot write {}: {e}", path.display()).into())
}

/// The share of a reconstruction's faces its simplified copy keeps.
const SIMPLIFIED_SHARE: usize = 10;

/// Reconstructs one point set, writes the mesh and its copy simplified to a tenth of the
/// faces, and a points | mesh | simplified preview of `(w, h)` pixels.
fn reconstruct_one(
    job: &ReconstructionJob,
    points: geosynth::core::PointSet,
    resolution: usize,
    (w, h): (u32, u32),
    out: &Path,
    globals: Globals,
) -> CliResult<ReconstructionEntry> {
    let input_points = points.len();
    let mut ctx = RunContext::new(0);
    let stage = Reconstruct {
        params: FieldParams::default()
            .resolution(resolution)
            .point_sign(job.sign),
    };
    let mesh = stage.run(points.clone(), &mut ctx)?;
    let seconds = |stage: &str| {
        ctx.timings()
            .iter()
            .find(|(n, _)| n.ends_with(stage))
            .map_or(0.0, |(_, d)| d.as_secs_f64())
    };
    let topology = mesh.topology();
    let simplify = Simplify {
        params: SimplifyParams::faces(mesh.face_count() / SIMPLIFIED_SHARE),
    };
    let started = Instant::now();
    let simplified = simplify.run(mesh.clone(), &mut RunContext::new(0))?;
    let simplify_seconds = started.elapsed().as_secs_f64();
    let simplified_topology = simplified.mesh.topology();
    let simplified_mesh = Geometry::Mesh(simplified.mesh);
    let mesh = Geometry::Mesh(mesh);
    // PLY for geometry tools, and glTF for Blender, three.js and game engines (the scans
    // are Y-up, as glTF's viewers expect).
    let options = WriteOptions::default().comment(format!("reconstructed from {}", job.name));
    let geometry_path = |ext: &str| {
        out.join("geometry")
            .join(format!("{}_reconstructed.{ext}", job.name))
    };
    write_geometry_file(&geometry_path("ply"), &mesh, &options, globals)?;
    write_geometry_file(&geometry_path("glb"), &mesh, &options, globals)?;
    let simplified_path = out
        .join("geometry")
        .join(format!("{}_simplified.ply", job.name));
    let simplified_options = WriteOptions::default().comment(format!(
        "reconstructed from {}, simplified to a tenth of its faces",
        job.name
    ));
    write_geometry_file(
        &simplified_path,
        &simplified_mesh,
        &simplified_options,
        globals,
    )?;
    let preview_path = out
        .join("previews")
        .join(format!("{}_reconstructed.png", job.name));
    let cloud = Geometry::Points(points);
    let panels = [
        preview::Panel::Geometry(&cloud, preview::UpAxis::Y),
        preview::Panel::Geometry(&mesh, preview::UpAxis::Y),
        preview::Panel::Geometry(&simplified_mesh, preview::UpAxis::Y),
    ];
    preview::save_png(
        &preview::render_panels(&panels, &RenderOptions::default().size(w, h))?,
        &preview_path,
    )?;
    let faces = mesh.mesh().map_or(0, |m| m.face_count());
    Ok(ReconstructionEntry {
        name: job.name.clone(),
        input: job.input.display().to_string(),
        input_points,
        sign: match job.sign {
            PointSign::Implicit => "local",
            PointSign::WindingNumber => "winding",
        },
        resolution,
        vertices: mesh.points().len(),
        faces,
        closed_manifold: topology.is_closed_manifold(),
        components: topology.components,
        euler_characteristic: topology.euler_characteristic,
        seconds_distance_field: seconds("distance field"),
        seconds_isosurface: seconds("iso-surface"),
        geometry: relative(&geometry_path("ply"), out),
        simplified: SimplifiedEntry {
            faces: simplified.report.faces_after,
            closed_manifold: simplified_topology.is_closed_manifold(),
            euler_characteristic: simplified_topology.euler_characteristic,
            max_collapse_error: simplified.report.max_collapse_error,
            seconds: simplify_seconds,
            geometry: relative(&simplified_path, out),
        },
        preview: relative(&preview_path, out),
    })
}

/// Quilts every texture fixture with the full method and both baselines.
fn quilt_textures(dir: &Path, args: &DemoArgs, globals: Globals) -> CliResult<Vec<QuiltEntry>> {
    // The quick run grows smaller outputs, at the library's default field resolution: at
    // half of it (24 nodes, the quick run's until the sixty-first session) the search
    // chose worse patches, and the flowers' full method scored below random placement.
    let scale = if args.quick { 1.25 } else { 2.0 };
    let (w, h) = if args.quick { (320, 240) } else { (560, 420) };
    let mut entries = Vec::new();
    // Each exemplar with the pairing weights of its Table 1 row.
    for (name, preset) in [
        ("quilt_bumpy", Table1Preset::HeightField),
        ("quilt_chain_mail", Table1Preset::ChainMail),
        ("quilt_weave", Table1Preset::Weave),
        ("quilt_flowers", Table1Preset::Flowers),
    ] {
        let path = dir.join(format!("{name}.ply"));
        let texture = if path.is_file() {
            geosynth::quilt::read_texture(&path)?
        } else {
            let made = geosynth::fixtures::textures::all(fixtures::FIXTURE_SEED)?;
            let exemplar = made
                .iter()
                .find(|t| t.name == name)
                .ok_or("missing texture fixture")?;
            geosynth::quilt::texture_from_exemplar(exemplar)?
        };
        let params = QuiltParams::default()
            .output(OutputSize::Scale(scale))
            .pairing(PairingParams::table1(preset))
            .seed(args.seed);
        let measure = measure_for(&texture, &params, globals);
        let full = measured_run(&texture, &params, &measure, globals, name)?;
        let search = measured_run(
            &texture,
            &params.clone().method(Method::SearchOnly),
            &measure,
            globals,
            "search only",
        )?;
        let random = measured_run(
            &texture,
            &params.clone().method(Method::RandomPlacement),
            &measure,
            globals,
            "random",
        )?;
        let pasted = measured_run(
            &texture,
            &params.same_layout_control(&full.output),
            &measure,
            globals,
            "same layout, pasted",
        )?;
        let geometry_path = args
            .out
            .join("geometry")
            .join(format!("{name}_quilted.ply"));
        let mut options =
            WriteOptions::default().comment(format!("quilted from {name} (seed {})", args.seed));
        for c in geosynth::quilt::texture_comments(&full.output.bounds, texture.up()) {
            options = options.comment(c);
        }
        write_geometry_file(
            &geometry_path,
            &Geometry::Points(full.output.points.clone()),
            &options,
            globals,
        )?;
        let preview_path = args
            .out
            .join("previews")
            .join(format!("{name}_quilted.png"));
        texture_preview(
            &texture,
            &[&full.output, &random.output],
            &preview_path,
            w,
            h,
        )?;
        // The demo's outputs are twice the exemplar, always room for quality windows.
        let (qf, qs, qr) = (
            full.quality.as_ref().map_err(String::clone)?,
            search.quality.as_ref().map_err(String::clone)?,
            random.quality.as_ref().map_err(String::clone)?,
        );
        let beats = |a: &QualityReport, b: &QualityReport| {
            a.neighbourhood_error < b.neighbourhood_error && a.seam_error < b.seam_error
        };
        entries.push(QuiltEntry {
            exemplar: name.to_string(),
            input_points: full.output.stats.input_points,
            scale,
            geometry: relative(&geometry_path, &args.out),
            preview: relative(&preview_path, &args.out),
            params: params.clone(),
            full: run_json(&full),
            search_only: run_json(&search),
            random_placement: run_json(&random),
            same_layout_pasted: run_json(&pasted),
            full_beats_baselines: beats(qf, qs) && beats(qf, qr),
        });
    }
    Ok(entries)
}

/// Synthesizes every Figure 6 solid (generated in memory) and measures the random-block
/// baseline beside it.
fn synthesize_volumes(args: &DemoArgs, globals: Globals) -> CliResult<Vec<VolumeEntry>> {
    use geosynth::voxel::{MatcherKind, VoxelExemplar, VoxelParams, VoxelSynth};
    // Full: the paper's setting (§6: source 64³, target 128³, 3 iterations, final block 16).
    let (source_resolution, target, levels, block) = if args.quick {
        (32, 64, 2, 8)
    } else {
        (64, 128, 3, 16)
    };
    let mut entries = Vec::new();
    for volume in fixtures::volumes::all(fixtures::FIXTURE_SEED)? {
        let exemplar = VoxelExemplar::from(&volume);
        // Twice the source along x and y; along z too for the cubic solids, while the flat
        // terrain keeps its height (rounded down to whole half blocks).
        let dims = geosynth::voxel::source_dims(&exemplar, source_resolution)?;
        let z = if dims[2] < dims[0] {
            (dims[2] / (block / 2) * (block / 2)).max(block)
        } else {
            target
        };
        let stage = VoxelSynth {
            source_resolution,
            params: VoxelParams::default()
                .target_dims([target, target, z])
                .levels(levels)
                .block(block)
                .matcher(MatcherKind::Brute)
                .seed(args.seed),
            ..VoxelSynth::default()
        };
        let run = crate::commands::voxel::measured_run(
            exemplar.clone(),
            &stage,
            true,
            globals,
            |_, _| Ok(()),
        )?;
        let dir = args.out.join("geometry");
        let write = |suffix: &str, geometry: &Geometry| -> CliResult<PathBuf> {
            let path = dir.join(format!("{}_{suffix}.ply", volume.name));
            write_geometry_file(
                &path,
                geometry,
                &WriteOptions::default().comment(volume.description),
                globals,
            )?;
            Ok(path)
        };
        let run_report = crate::commands::voxel::run_json(&run, &stage);
        let exemplar_path = write("exemplar", &Geometry::Mesh(volume.mesh.clone()))?;
        let copied = Geometry::Mesh(run.output.copied.mesh);
        let copied_path = write("synthesized", &copied)?;
        let isosurface = Geometry::Mesh(run.output.isosurface);
        let iso_path = write("isosurface", &isosurface)?;
        let preview_path = args
            .out
            .join("previews")
            .join(format!("{}_synthesized.png", volume.name));
        crate::commands::voxel::voxel_preview(
            &exemplar,
            &copied,
            &isosurface,
            &preview_path,
            if args.quick { 240 } else { 400 },
        )?;
        let beats_baseline = run.baseline.as_ref().is_some_and(|b| {
            run.quality.neighbourhood_error < b.neighbourhood_error
                && run.quality.seam_error < b.seam_error
                && run.quality.distance_field_fraction > b.distance_field_fraction
        });
        entries.push(VolumeEntry {
            exemplar: volume.name.to_string(),
            exemplar_geometry: relative(&exemplar_path, &args.out),
            geometry: relative(&copied_path, &args.out),
            isosurface: relative(&iso_path, &args.out),
            preview: relative(&preview_path, &args.out),
            run: run_report,
            beats_baseline,
        });
    }
    Ok(entries)
}

#[cfg(test)]
mod tests {
    use super::counted;

    #[test]
    fn the_summary_names_one_in_the_singular_and_others_in_the_plural() {
        assert_eq!(counted(1, "height map"), "1 height map");
        assert_eq!(counted(0, "quilt"), "0 quilts");
        assert_eq!(counted(5, "solid"), "5 solids");
    }
}
